//! Sensor (film gate) formats and how an image's pixels map onto them.

use super::lens::{require_finite, OpticsError};

/// The active area of a sensor or film frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensor {
    pub width_mm: f64,
    pub height_mm: f64,
}

/// Which sensor dimension spans which image dimension (Blender's `sensor_fit`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SensorFit {
    /// The sensor width spans the image width.
    Horizontal,
    /// The sensor height spans the image height.
    Vertical,
    /// The sensor width spans the larger image dimension.
    Auto,
}

impl SensorFit {
    /// The fit as `--sensor-fit` and Blender's sensor fit name it.
    pub fn name(self) -> &'static str {
        match self {
            SensorFit::Horizontal => "horizontal",
            SensorFit::Vertical => "vertical",
            SensorFit::Auto => "auto",
        }
    }
}

/// Named formats: (aliases, width in mm, height in mm). The first alias is the canonical name.
const FORMATS: &[(&[&str], f64, f64)] = &[
    (&["full-frame", "ff", "35mm"], 36.0, 24.0),
    (&["super35"], 24.89, 18.66),
    (&["aps-c"], 23.6, 15.6),
    (&["aps-c-canon"], 22.3, 14.9),
    (&["micro-four-thirds", "m43"], 17.3, 13.0),
    (&["1in"], 13.2, 8.8),
    (&["apsh"], 27.9, 18.6),
    (&["medium-format"], 43.8, 32.9),
];

impl Sensor {
    /// 135 film / full frame, 36 x 24 mm.
    pub const FULL_FRAME: Sensor = Sensor { width_mm: 36.0, height_mm: 24.0 };

    /// A sensor of the given size; both sides must be finite and positive.
    pub fn new(width_mm: f64, height_mm: f64) -> Result<Sensor, OpticsError> {
        require_finite("sensor width (mm)", width_mm)?;
        require_finite("sensor height (mm)", height_mm)?;
        if width_mm <= 0.0 || height_mm <= 0.0 {
            return Err(OpticsError::InvalidSensorSize { width_mm, height_mm });
        }
        Ok(Sensor { width_mm, height_mm })
    }

    /// Parses a format name (case-insensitive, see [`Sensor::known_names`]) or a size
    /// `WxH` / `WxHmm` in millimetres, e.g. `36x20.25`.
    pub fn parse(text: &str) -> Result<Sensor, OpticsError> {
        let key = text.trim().to_ascii_lowercase();
        if let Some(&(_, w, h)) = FORMATS.iter().find(|(names, ..)| names.contains(&key.as_str())) {
            return Ok(Sensor { width_mm: w, height_mm: h });
        }
        let size = key.strip_suffix("mm").unwrap_or(&key);
        let parsed = size
            .split_once('x')
            .and_then(|(w, h)| Some((w.trim().parse::<f64>().ok()?, h.trim().parse::<f64>().ok()?)));
        match parsed {
            Some((w, h)) => Sensor::new(w, h).map_err(|_| OpticsError::InvalidSensorSize { width_mm: w, height_mm: h }),
            None => Err(OpticsError::UnknownSensor { text: text.to_string(), known: Self::known_names().join(", ") }),
        }
    }

    /// Every accepted format name, aliases included.
    pub fn known_names() -> Vec<&'static str> {
        FORMATS.iter().flat_map(|(names, ..)| names.iter().copied()).collect()
    }

    /// The diagonal K used for the diagonal field of view (Kyaw 2013 eq 3.8).
    pub fn diagonal_mm(&self) -> f64 {
        self.width_mm.hypot(self.height_mm)
    }

    /// Size of one (square) pixel on the sensor, in mm, for an image of the given size:
    /// `Horizontal` maps the sensor width to the image width, `Vertical` the sensor height to
    /// the image height, `Auto` the sensor width to the larger image dimension. A zero pixel
    /// count gives infinity.
    pub fn pixel_pitch_mm(&self, width_px: u32, height_px: u32, fit: SensorFit) -> f64 {
        match fit {
            SensorFit::Horizontal => self.width_mm / f64::from(width_px),
            SensorFit::Vertical => self.height_mm / f64::from(height_px),
            SensorFit::Auto => self.width_mm / f64::from(width_px.max(height_px)),
        }
    }

    /// The part of the image plane (width, height in mm) the image actually covers under `fit`.
    /// It may overhang the sensor in the other dimension when the aspect ratios differ.
    pub fn image_extent_mm(&self, width_px: u32, height_px: u32, fit: SensorFit) -> (f64, f64) {
        let pitch_mm = self.pixel_pitch_mm(width_px, height_px, fit);
        (pitch_mm * f64::from(width_px), pitch_mm * f64::from(height_px))
    }
}

impl std::str::FromStr for Sensor {
    type Err = OpticsError;
    fn from_str(text: &str) -> Result<Self, Self::Err> {
        Sensor::parse(text)
    }
}

impl std::fmt::Display for Sensor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} x {} mm", self.width_mm, self.height_mm)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_named_formats_case_insensitively() {
        let expect = [
            ("full-frame", 36.0, 24.0),
            ("FF", 36.0, 24.0),
            (" 35mm ", 36.0, 24.0),
            ("Super35", 24.89, 18.66),
            ("APS-C", 23.6, 15.6),
            ("aps-c-canon", 22.3, 14.9),
            ("Micro-Four-Thirds", 17.3, 13.0),
            ("m43", 17.3, 13.0),
            ("1in", 13.2, 8.8),
            ("apsh", 27.9, 18.6),
            ("medium-format", 43.8, 32.9),
        ];
        for (text, w, h) in expect {
            assert_eq!(Sensor::parse(text).unwrap(), Sensor { width_mm: w, height_mm: h }, "{text}");
        }
        assert_eq!("ff".parse::<Sensor>().unwrap(), Sensor::FULL_FRAME);
    }

    #[test]
    fn parses_explicit_sizes() {
        let s = Sensor { width_mm: 36.0, height_mm: 20.25 };
        for text in ["36x20.25", "36x20.25mm", "36X20.25MM", "36 x 20.25 mm"] {
            assert_eq!(Sensor::parse(text).unwrap(), s, "{text}");
        }
        assert_eq!(Sensor::parse("6.17x4.55").unwrap().height_mm, 4.55);
    }

    #[test]
    fn rejects_unknown_and_invalid_text() {
        let err = Sensor::parse("vistavision").unwrap_err().to_string();
        assert!(err.contains("\"vistavision\""), "{err}");
        for name in Sensor::known_names() {
            assert!(err.contains(name), "{err} lacks {name}");
        }
        for text in ["", "x", "36x", "36x24x2", "axb", "36x24cm"] {
            assert!(matches!(Sensor::parse(text), Err(OpticsError::UnknownSensor { .. })), "{text}");
        }
        for text in ["0x24", "-36x24", "36x0", "infx24", "nanx24"] {
            let err = Sensor::parse(text).unwrap_err();
            assert!(matches!(err, OpticsError::InvalidSensorSize { .. }), "{text}: {err}");
        }
        assert!(Sensor::parse("-36x24").unwrap_err().to_string().contains("-36 x 24 mm"));
    }

    #[test]
    fn diagonal_and_pixel_pitch() {
        assert!((Sensor::FULL_FRAME.diagonal_mm() - 43.266_615).abs() < 1e-6);
        let s = Sensor::FULL_FRAME;
        assert_eq!(s.pixel_pitch_mm(1920, 1080, SensorFit::Horizontal), 36.0 / 1920.0);
        assert_eq!(s.pixel_pitch_mm(1920, 1080, SensorFit::Vertical), 24.0 / 1080.0);
        assert_eq!(s.pixel_pitch_mm(1920, 1080, SensorFit::Auto), 36.0 / 1920.0);
        // Portrait image: Auto puts the sensor width along the (larger) image height.
        assert_eq!(s.pixel_pitch_mm(1080, 1920, SensorFit::Auto), 36.0 / 1920.0);
        assert_eq!(s.image_extent_mm(1920, 1080, SensorFit::Horizontal), (36.0, 20.25));
        assert_eq!(s.pixel_pitch_mm(0, 0, SensorFit::Horizontal), f64::INFINITY);
    }
}
