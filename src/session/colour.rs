//! The frame's working colour space and the preview's display and view (OpenColorIO).

use super::ColourSettings;
use crate::io::colour_config::{ColourConfig, ColourConfigError, DisplayView};
use crate::model::frame::Frame;
use crate::optics::colour::{named_space, space_name, Chromaticities, NAMED_SPACES};
use anyhow::{bail, Context, Result};
use std::sync::{Arc, Mutex};

/// Sets the frame's colour space from --colorspace (else it keeps the colour file's
/// chromaticities, or Rec.709); the `--explain` line that says which, with its luminance
/// weights; and the preview's display and view when there is an OpenColorIO config.
pub(super) fn choose_working_space(
    args: &ColourSettings,
    wants_png: bool,
    frame: &mut Frame,
) -> Result<(String, Option<Arc<DisplayView>>)> {
    let from_file = frame.working_space;
    let config = match &args.config {
        Some(path) => Some(memo(&CONFIG, path.clone(), || ColourConfig::load(path).context("--config"))?),
        None => match std::env::var("OCIO") {
            Ok(path) if !path.is_empty() => Some(memo(&CONFIG, format!("$OCIO={path}"), || {
                ColourConfig::from_env().context("$OCIO")?.context("$OCIO is empty")
            })?),
            _ => None,
        },
    };
    let mut config_space = None;
    let (name, how) = match (&args.colorspace, &config) {
        (Some(text), Some(config)) => {
            let (name, space) = config.working_space(text).context(format!("--colorspace {text:?}"))?;
            frame.working_space = space;
            config_space = Some(name.clone());
            // A file stores its chromaticities as 32-bit floats.
            let differs = if same_space(&from_file, &space) { "" } else { ", not the file's chromaticities" };
            (name, format!("--colorspace in OpenColorIO config {}{differs}", config.name))
        }
        (Some(text), None) => {
            let Some((name, space)) = named_space(text) else {
                let known: Vec<&str> = NAMED_SPACES.iter().map(|(name, _, _)| *name).collect();
                bail!(
                    "--colorspace {text:?}: not a colour space realcam knows; known: {} (or any space of an \
                     OpenColorIO config: --config FILE, $OCIO)",
                    known.join(", ")
                );
            };
            frame.working_space = space;
            let differs = if space_name(&from_file) != Some(name) { ", not the file's chromaticities" } else { "" };
            (name.to_string(), format!("--colorspace{differs}"))
        }
        (None, _) => {
            let name = space_name(&from_file).unwrap_or("custom primaries");
            // The config's space of these primaries: the one of realcam's name, else its
            // scene_linear role.
            if let Some(config) = &config {
                config_space = [name, "scene_linear"]
                    .into_iter()
                    .filter_map(|n| config.working_space(n).ok())
                    .find(|(_, space)| same_space(space, &from_file))
                    .map(|(n, _)| n);
            }
            (name.to_string(), "the colour file's chromaticities, or Rec.709 without them".to_string())
        }
    };
    let [r, g, b] = frame.working_space.luminance_weights();
    let [nm_r, nm_g, nm_b] = frame.channel_wavelengths_nm();
    let line = format!(
        "colour space: {name} ({how}); luminance = {r:.4} R + {g:.4} G + {b:.4} B; chromatic effects at \
         {nm_r:.1}, {nm_g:.1}, {nm_b:.1} nm (the primaries' dominant wavelengths)"
    );
    let wants_view = wants_png || args.display.is_some() || args.view.is_some();
    let display_view = match (&config, config_space) {
        (Some(config), Some(space)) if wants_view => {
            let key = (config.name.clone(), space.clone(), args.display.clone(), args.view.clone());
            Some(memo(&VIEW, key, || {
                config.display_view(&space, args.display.as_deref(), args.view.as_deref()).map_err(|e| {
                    let flag =
                        if matches!(e, ColourConfigError::UnknownDisplay { .. }) { "--display" } else { "--view" };
                    anyhow::Error::new(e).context(flag)
                })
            })?)
        }
        (Some(config), None) if args.display.is_some() || args.view.is_some() => bail!(
            "--display/--view: OpenColorIO config {} has no colour space of the input's primaries ({name}); \
             name it with --colorspace",
            config.name
        ),
        (None, _) if args.display.is_some() || args.view.is_some() => {
            bail!("--display/--view: no OpenColorIO config (--config FILE, $OCIO)")
        }
        _ => None,
    };
    Ok((line, display_view))
}

/// The OpenColorIO config and the preview's view of the run, made once: a sequence plans every
/// frame with the same ones (reading the config and building the view took about 18 ms a frame).
type Memo<K, V> = Mutex<Option<(K, Arc<V>)>>;
static CONFIG: Memo<String, ColourConfig> = Mutex::new(None);
static VIEW: Memo<(String, String, Option<String>, Option<String>), DisplayView> = Mutex::new(None);

/// `cell`'s value if it was made for `key`, else `make`'s, kept for the next call.
fn memo<K: PartialEq, V>(cell: &Memo<K, V>, key: K, make: impl FnOnce() -> Result<V>) -> Result<Arc<V>> {
    // A poisoned lock only means another thread panicked while holding it: make it again.
    let mut kept = cell.lock().unwrap_or_else(|e| e.into_inner());
    if let Some((k, v)) = kept.as_ref() {
        if *k == key {
            return Ok(v.clone());
        }
    }
    let value = Arc::new(make()?);
    *kept = Some((key, value.clone()));
    Ok(value)
}

/// The same primaries and white within 1e-6 (a file stores them as 32-bit floats).
fn same_space(a: &Chromaticities, b: &Chromaticities) -> bool {
    let coords = |c: &Chromaticities| [c.red, c.green, c.blue, c.white].concat();
    coords(a).iter().zip(coords(b)).all(|(x, y)| (x - y).abs() < 1e-6)
}
