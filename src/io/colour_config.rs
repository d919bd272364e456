//! OpenColorIO configs (issue 16, part 1) through the pure-Rust `ocio` crate: a config from a
//! file, `$OCIO`, or a built-in one (`ocio://cg-config-latest`, ...), and the working colour
//! space a config names, as the [`Chromaticities`] the passes use.
//!
//! A space's primaries come from the config's own processor: RGB (1, 0, 0), (0, 1, 0),
//! (0, 0, 1) converted to the default built-in config's "Linear Rec.709 (sRGB)" through the
//! configs' interchange roles. OpenColorIO adapts whites by Bradford, so that matrix is
//! [`Chromaticities::rgb_to_adapted`] of the space's primaries: a space realcam knows by its
//! primaries (ACEScg, ACES2065-1, Rec.709, Rec.2020, P3-D65) is recognised within 1e-4 and keeps
//! its own primaries and white; any other linear space gets the primaries of that matrix with
//! D65's white (its luminance weights are then the adapted space's).

use crate::optics::colour::{Chromaticities, NAMED_SPACES};

/// The built-in config's linear Rec.709 space every space is measured against.
const REC709_BUILTIN: &str = "Linear Rec.709 (sRGB)";

/// Every failure of a config; each names the config and, where relevant, the colour space.
#[derive(Debug, thiserror::Error)]
pub enum ColourConfigError {
    #[error("OpenColorIO config {config}: cannot read it: {message}")]
    Load { config: String, message: String },
    #[error("OpenColorIO config {config}: no colour space {space:?}; its colour spaces: {known}")]
    UnknownSpace { config: String, space: String, known: String },
    #[error("OpenColorIO config {config}: colour space {space:?} cannot be converted to Rec.709: {message}")]
    Convert { config: String, space: String, message: String },
    #[error("OpenColorIO config {config}: colour space {space:?} is not linear (realcam's passes add light, so the input must be scene-linear)")]
    NotLinear { config: String, space: String },
    #[error("OpenColorIO config {config}: colour space {space:?} has no usable primaries: {message}")]
    Primaries { config: String, space: String, message: String },
    #[error("OpenColorIO config {config}: no display {display:?}; its displays: {known}")]
    UnknownDisplay { config: String, display: String, known: String },
    #[error("OpenColorIO config {config}: display {display:?} has no view {view:?} for {space:?}; its views: {known}")]
    UnknownView { config: String, display: String, view: String, space: String, known: String },
}

/// The most YAML nodes a config may hold with its aliases expanded (the largest built-in
/// configs hold under 100,000).
const MAX_YAML_NODES: u64 = 10_000_000;

/// Counts the nodes of YAML `text` as a reader that copies every alias sees them, without
/// copying: Err naming the bound when they pass [`MAX_YAML_NODES`] (a "billion laughs" of
/// nested aliases), or the YAML error.
fn check_yaml_size(text: &str) -> Result<(), String> {
    use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
    use yaml_rust2::scanner::Marker;
    #[derive(Default)]
    struct Count {
        /// The nodes of each collection open (its anchor, its nodes so far).
        open: Vec<(usize, u64)>,
        /// The nodes of each anchored node.
        anchored: std::collections::HashMap<usize, u64>,
        total: u64,
    }
    impl Count {
        fn add(&mut self, anchor: usize, nodes: u64) {
            if anchor > 0 {
                self.anchored.insert(anchor, nodes);
            }
            match self.open.last_mut() {
                Some((_, n)) => *n = n.saturating_add(nodes),
                None => self.total = self.total.saturating_add(nodes),
            }
        }
        fn largest(&self) -> u64 {
            self.open.iter().fold(self.total, |m, (_, n)| m.saturating_add(*n))
        }
    }
    impl MarkedEventReceiver for Count {
        fn on_event(&mut self, event: Event, _mark: Marker) {
            match event {
                Event::Scalar(_, _, anchor, _) => self.add(anchor, 1),
                Event::SequenceStart(anchor, _) | Event::MappingStart(anchor, _) => self.open.push((anchor, 1)),
                Event::SequenceEnd | Event::MappingEnd => {
                    if let Some((anchor, n)) = self.open.pop() {
                        self.add(anchor, n);
                    }
                }
                Event::Alias(id) => {
                    let n = self.anchored.get(&id).copied().unwrap_or(1);
                    self.add(0, n);
                }
                _ => {}
            }
        }
    }
    let mut count = Count::default();
    let mut parser = Parser::new_from_str(text);
    let mut events = 0u64;
    loop {
        let (event, mark) = parser.next_token().map_err(|e| e.to_string())?;
        let end = matches!(event, Event::StreamEnd);
        count.on_event(event, mark);
        events += 1;
        if count.largest() > MAX_YAML_NODES || events > MAX_YAML_NODES {
            return Err(format!(
                "its YAML holds more than {MAX_YAML_NODES} nodes with its aliases expanded (nested aliases, a \"billion laughs\")"
            ));
        }
        if end {
            return Ok(());
        }
    }
}

/// The most colour spaces a config may define: the ocio crate's reading grows as the square of
/// their number (30,000 took 40 s, issue 34); the ACES studio config defines under 300.
const MAX_COLOUR_SPACES: usize = 4096;

/// Err naming the bound when YAML `text` defines more than [`MAX_COLOUR_SPACES`] colour spaces
/// (`!<ColorSpace>` tags, counted in the text before any parse).
fn check_colour_space_count(text: &str) -> Result<(), String> {
    let count = text.matches("!<ColorSpace>").count();
    if count > MAX_COLOUR_SPACES {
        return Err(format!(
            "it defines {count} colour spaces, more than the {MAX_COLOUR_SPACES} realcam reads (reading them takes time \
             growing as the square of their number)"
        ));
    }
    Ok(())
}

/// The files a config file names as the `src` of its file transforms (LUTs), found along its
/// `search_path` (relative to the config's folder; absolute `src` as it is), where they exist:
/// inputs no output may replace. Best effort: a config that does not parse names none (its
/// own error comes when it is loaded), and context variables (`$SHOT`) are not expanded.
pub fn config_lut_files(config: &std::path::Path) -> Vec<std::path::PathBuf> {
    use yaml_rust2::parser::{Event, Parser};
    let Ok(text) = std::fs::read_to_string(config) else { return Vec::new() };
    // Per open collection: a mapping's last key and whether a key comes next; a sequence's key
    // in the mapping around it.
    let mut open: Vec<(bool, String, bool)> = Vec::new();
    let (mut sources, mut search) = (Vec::new(), Vec::new());
    let mut parser = Parser::new_from_str(&text);
    let mut events = 0u64;
    while let Ok((event, _)) = parser.next_token() {
        events += 1;
        if events > MAX_YAML_NODES {
            break;
        }
        // The key a value or collection starting now belongs to (None: not a mapping's value).
        fn value_key(open: &mut [(bool, String, bool)]) -> Option<String> {
            match open.last_mut() {
                Some((true, key, key_next)) => {
                    let was_key = *key_next;
                    *key_next = !*key_next;
                    (!was_key).then(|| key.clone())
                }
                Some((false, key, _)) => Some(key.clone()),
                None => None,
            }
        }
        match event {
            Event::Scalar(value, ..) => {
                let is_key = matches!(open.last(), Some((true, _, true)));
                match value_key(&mut open) {
                    Some(key) if key == "src" => sources.push(value),
                    Some(key) if key == "search_path" => search.extend(value.split(':').map(str::to_string)),
                    _ if is_key => {
                        if let Some((_, key, _)) = open.last_mut() {
                            *key = value;
                        }
                    }
                    _ => {}
                }
            }
            Event::MappingStart(..) => {
                value_key(&mut open);
                open.push((true, String::new(), true));
            }
            Event::SequenceStart(..) => {
                let key = value_key(&mut open).unwrap_or_default();
                open.push((false, key, false));
            }
            Event::MappingEnd | Event::SequenceEnd => {
                open.pop();
            }
            Event::Alias(_) => {
                value_key(&mut open);
            }
            Event::StreamEnd => break,
            _ => {}
        }
    }
    let folder = config.parent().unwrap_or(std::path::Path::new("."));
    if search.is_empty() {
        search.push(".".into());
    }
    let mut files = Vec::new();
    for src in sources {
        let src = std::path::Path::new(&src);
        let candidates: Vec<std::path::PathBuf> = if src.is_absolute() {
            vec![src.to_path_buf()]
        } else {
            search.iter().map(|d| folder.join(d).join(src)).collect()
        };
        files.extend(candidates.into_iter().filter(|c| c.is_file()));
    }
    files
}

/// A display and view of a config and the processor from a working space to its display
/// values (encoded for the display: an sRGB display's values carry the sRGB curve).
pub struct DisplayView {
    /// The config's name of the colour space the processor starts from.
    pub space: String,
    pub display: String,
    pub view: String,
    pub processor: ocio::CpuProcessor,
}

/// A loaded config and how it was named (the file, `$OCIO`'s file, or the built-in URI).
pub struct ColourConfig {
    pub config: ocio::Config,
    pub name: String,
}

impl ColourConfig {
    /// A config file (`.ocio`, `.ocioz`) or a built-in config's URI (`ocio://cg-config-latest`).
    pub fn load(path_or_uri: &str) -> Result<Self, ColourConfigError> {
        let name =
            if path_or_uri.starts_with("ocio://") { path_or_uri.to_string() } else { format!("\"{path_or_uri}\"") };
        if !path_or_uri.starts_with("ocio://") {
            // A text config (not an .ocioz archive) whose aliases would expand past the bound
            // is refused before the ocio crate, which copies every alias, reads it.
            if let Ok(text) = std::fs::read_to_string(path_or_uri) {
                check_yaml_size(&text)
                    .and_then(|()| check_colour_space_count(&text))
                    .map_err(|message| ColourConfigError::Load { config: name.clone(), message })?;
            }
        }
        let config = ocio::Config::create_from_file(path_or_uri)
            .map_err(|e| ColourConfigError::Load { config: name.clone(), message: e.to_string() })?;
        Ok(ColourConfig { config, name })
    }

    /// The config `$OCIO` names, if it is set and not empty.
    pub fn from_env() -> Result<Option<Self>, ColourConfigError> {
        match std::env::var("OCIO") {
            Ok(path) if !path.is_empty() => {
                let mut c = Self::load(&path)?;
                c.name = format!("{} from $OCIO", c.name);
                Ok(Some(c))
            }
            _ => Ok(None),
        }
    }

    /// The config's name of `space` (an alias or role resolved), and its primaries and white.
    pub fn working_space(&self, space: &str) -> Result<(String, Chromaticities), ColourConfigError> {
        let config = self.name.clone();
        let Some(cs) = self.config.get_color_space(space) else {
            let n = self.config.num_color_spaces();
            let known: Vec<&str> = (0..n).map(|i| self.config.color_space_name_by_index(i)).collect();
            return Err(ColourConfigError::UnknownSpace { config, space: space.to_string(), known: known.join(", ") });
        };
        let canonical = cs.name().to_string();
        let err =
            |message: String| ColourConfigError::Convert { config: config.clone(), space: canonical.clone(), message };
        let processor = ocio::Config::get_processor_to_builtin_color_space(&self.config, &canonical, REC709_BUILTIN)
            .map_err(|e| err(e.to_string()))?
            .default_cpu_processor();
        let apply = |v: [f64; 3]| {
            let mut rgb = v.map(|x| x as f32);
            processor.apply_rgb(&mut rgb);
            rgb.map(f64::from)
        };
        let columns = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(apply);
        let m = [0, 1, 2].map(|i| [0, 1, 2].map(|j| columns[j][i]));
        // Linear: a mix of the primaries, and the same mix 16 times brighter, land where the
        // matrix says.
        for v in [[0.3, 0.5, 0.2], [4.8, 8.0, 3.2]] {
            let want = crate::optics::colour::mul_vec(&m, v);
            let got = apply(v);
            let scale = want.iter().fold(1.0f64, |s, x| s.max(x.abs()));
            if (0..3).any(|i| !got[i].is_finite() || (got[i] - want[i]).abs() > 1e-4 * scale) {
                return Err(ColourConfigError::NotLinear { config, space: canonical });
            }
        }
        let close = |a: &[[f64; 3]; 3]| (0..3).all(|i| (0..3).all(|j| (a[i][j] - m[i][j]).abs() < 1e-4));
        if let Some((_, _, c)) = NAMED_SPACES.iter().find(|(_, _, c)| close(&c.rgb_to_adapted(&Chromaticities::REC709)))
        {
            return Ok((canonical, *c));
        }
        // The adapted primaries: XYZ (D65) of each column, as xy.
        let xyz = Chromaticities::REC709.rgb_to_xyz();
        let xy = |col: [f64; 3]| {
            let p = crate::optics::colour::mul_vec(&xyz, col);
            let sum = p[0] + p[1] + p[2];
            [p[0] / sum, p[1] / sum]
        };
        Chromaticities::new(xy(columns[0]), xy(columns[1]), xy(columns[2]), Chromaticities::REC709.white)
            .map(|c| (canonical.clone(), c))
            .map_err(|e| ColourConfigError::Primaries {
                config: config.clone(),
                space: canonical.clone(),
                message: e.to_string(),
            })
    }
}

impl ColourConfig {
    /// The processor from `space` through `display`'s `view`; without them the config's
    /// default display (its first active one) and that display's default view for `space`
    /// (viewing rules, else its first active view): for the ACES configs the sRGB display and
    /// the ACES output transform.
    pub fn display_view(
        &self,
        space: &str,
        display: Option<&str>,
        view: Option<&str>,
    ) -> Result<DisplayView, ColourConfigError> {
        let c = &self.config;
        let config = self.name.clone();
        let displays: Vec<String> = (0..c.num_displays()).map(|i| c.display(i)).collect();
        let display = display.map_or_else(|| c.default_display(), str::to_string);
        if !displays.contains(&display) {
            return Err(ColourConfigError::UnknownDisplay { config, display, known: displays.join(", ") });
        }
        let views: Vec<String> = (0..c.num_views(&display)).map(|i| c.view(&display, i)).collect();
        let view = match view {
            Some(v) => v.to_string(),
            None => c
                .default_view_for_color_space(&display, space)
                .ok()
                .filter(|v| !v.is_empty())
                .unwrap_or_else(|| c.default_view(&display)),
        };
        if !views.contains(&view) {
            let known = views.join(", ");
            return Err(ColourConfigError::UnknownView { config, display, view, space: space.to_string(), known });
        }
        let processor = c
            .get_display_view_processor(space, &display, &view)
            .map_err(|e| ColourConfigError::Convert { config, space: space.to_string(), message: e.to_string() })?
            .default_cpu_processor();
        Ok(DisplayView { space: space.to_string(), display, view, processor })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_config_of_more_colour_spaces_than_the_bound_is_refused_before_it_is_read() {
        // Issue 34: 30,000 colour spaces took the ocio crate 40 s (quadratic in their number).
        let space = "  - !<ColorSpace>\n    name: s\n";
        let text = format!("ocio_profile_version: 2\ncolorspaces:\n{}", space.repeat(MAX_COLOUR_SPACES + 1));
        let dir = crate::io::test_dir("ocio-spaces");
        let path = dir.join("many.ocio");
        std::fs::write(&path, &text).unwrap();
        let err = ColourConfig::load(path.to_str().unwrap()).map(|_| ()).unwrap_err().to_string();
        assert!(
            err.ends_with(
                "it defines 4097 colour spaces, more than the 4096 realcam reads (reading them takes time growing as \
                 the square of their number)"
            ),
            "{err}"
        );
        assert!(check_colour_space_count(&space.repeat(MAX_COLOUR_SPACES)).is_ok());
    }

    #[test]
    fn the_aces_configs_spaces_have_realcams_primaries() {
        let c = ColourConfig::load("ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5").unwrap();
        for (name, want) in [
            ("ACEScg", Chromaticities::ACES_AP1),
            ("ACES2065-1", Chromaticities::ACES_AP0),
            ("Linear Rec.2020", Chromaticities::REC2020),
            ("Linear P3-D65", Chromaticities::P3_D65),
            ("Linear Rec.709 (sRGB)", Chromaticities::REC709),
        ] {
            assert_eq!(c.working_space(name).unwrap(), (name.to_string(), want));
        }
        // An alias and a role resolve to the space's own name.
        assert_eq!(c.working_space("lin_ap1").unwrap().0, "ACEScg");
        assert_eq!(c.working_space("scene_linear").unwrap().0, "ACEScg");
    }

    /// A linear space with primaries realcam does not know: Adobe RGB (1998) (D65; Adobe RGB
    /// (1998) Color Image Encoding sec. 4.3.1.1: red 0.64, 0.33, green 0.21, 0.71, blue 0.15,
    /// 0.06) comes back with its primaries.
    #[test]
    fn other_linear_spaces_get_their_primaries_from_the_processor() {
        let c = ColourConfig::load("ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5").unwrap();
        let (_, adobe) = c.working_space("Linear AdobeRGB").unwrap();
        for (got, want) in [adobe.red, adobe.green, adobe.blue, adobe.white].iter().zip([
            [0.64, 0.33],
            [0.21, 0.71],
            [0.15, 0.06],
            [0.3127, 0.3290],
        ]) {
            assert!((got[0] - want[0]).abs() < 2e-4 && (got[1] - want[1]).abs() < 2e-4, "{got:?} vs {want:?}");
        }
    }

    #[test]
    fn errors_name_the_config_and_the_space() {
        let c = ColourConfig::load("ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5").unwrap();
        let e = c.working_space("ACEScgg").unwrap_err().to_string();
        assert!(e.starts_with("OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: no colour space \"ACEScgg\"; its colour spaces: "), "{e}");
        assert!(e.contains("ACES2065-1, ACEScc, ACEScct, ACEScg"), "{e}");
        let e = c.working_space("sRGB Encoded Rec.709 (sRGB)").unwrap_err().to_string();
        assert!(e.contains("colour space \"sRGB Encoded Rec.709 (sRGB)\" is not linear"), "{e}");
        let e = ColourConfig::load("/nonexistent/config.ocio").err().unwrap().to_string();
        assert!(e.starts_with("OpenColorIO config \"/nonexistent/config.ocio\": cannot read it:"), "{e}");
    }

    /// The ACES config's defaults are the sRGB display's ACES 2.0 output transform; 18 % grey
    /// in ACEScg shows at 0.3491874 (PyOpenColorIO 2.6.0, scripts/ocio-reference.py).
    #[test]
    fn the_default_display_view_is_the_aces_output_transform() {
        let c = ColourConfig::load("ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5").unwrap();
        let dv = c.display_view("ACEScg", None, None).unwrap();
        assert_eq!((dv.display.as_str(), dv.view.as_str()), ("sRGB - Display", "ACES 2.0 - SDR 100 nits (Rec.709)"));
        let mut grey = [0.18f32; 3];
        dv.processor.apply_rgb(&mut grey);
        assert!(grey.iter().all(|v| (v - 0.3491874).abs() < 1e-5), "{grey:?}");
        let e = c.display_view("ACEScg", Some("sRGB - Display"), Some("Filmic")).err().unwrap().to_string();
        assert!(
            e.starts_with(
                "OpenColorIO config ocio://cg-config-v4.0.0_aces-v2.0_ocio-v2.5: display \"sRGB - Display\" has no view \
                 \"Filmic\" for \"ACEScg\"; its views: "
            ),
            "{e}"
        );
        let e = c.display_view("ACEScg", Some("sRGB"), None).err().unwrap().to_string();
        assert!(e.contains("no display \"sRGB\"; its displays: sRGB - Display, "), "{e}");
    }
}
