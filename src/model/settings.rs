//! Settings written as text: a shutter time (`1/50` or `0.02`), a spherical aberration amount
//! (a number or `uniform`), an image size (`1920x1080`). A message says what is wrong with the
//! text; whoever got the text names where it came from (`--shutter "0": must be a positive time
//! in seconds`).

use std::num::ParseFloatError;

#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    #[error(transparent)]
    Number(#[from] ParseFloatError),
    #[error("must be a positive time in seconds")]
    NotAPositiveTime,
    #[error("a number in [-1, 1] or 'uniform'")]
    SphericalAberration(#[source] ParseFloatError),
    #[error("{text:?} is not WIDTHxHEIGHT")]
    NotASize { text: String },
    #[error("{text:?} is not X,Y,ENERGY[,AREA] (pixels; the energy a sum of scene values over pixels, at least 0)")]
    NotAFlareLight { text: String },
    #[error("{text:?} is not `none`, a diameter in px (64, 64px) or on the film in mm (1.2mm)")]
    NotACocLimit { text: String },
    #[error("{text:?} is not a size in bytes from 1 byte to below 1 EB: a number with K, M, G or T (powers of 1000, an optional B), or KiB, MiB, GiB, TiB")]
    NotBytes { text: String },
}

/// A clamp on the CoC diameter: `none`, pixels (`64`, `64px`) or mm on the film (`1.2mm`).
/// The range is checked where the camera is built.
pub fn parse_coc_limit(text: &str) -> Result<crate::model::camera::CocLimit, SettingError> {
    use crate::model::camera::CocLimit;
    let t = text.trim();
    if t.eq_ignore_ascii_case("none") {
        return Ok(CocLimit::None);
    }
    let (number, make): (&str, fn(f64) -> CocLimit) = match t.strip_suffix("mm") {
        Some(n) => (n, CocLimit::FilmMm),
        None => (t.strip_suffix("px").unwrap_or(t), CocLimit::Px),
    };
    number.trim().parse::<f64>().map(make).map_err(|_| SettingError::NotACocLimit { text: text.to_string() })
}

/// A shutter time in seconds, as a fraction (`1/50`) or a decimal (`0.02`); it must be
/// positive and finite.
pub fn parse_shutter_s(text: &str) -> Result<f64, SettingError> {
    let shutter_s = match text.split_once('/') {
        Some((a, b)) => a.trim().parse::<f64>()? / b.trim().parse::<f64>()?,
        None => text.trim().parse()?,
    };
    if shutter_s.is_finite() && shutter_s > 0.0 {
        Ok(shutter_s)
    } else {
        Err(SettingError::NotAPositiveTime)
    }
}

/// A spherical aberration amount: a number, or `uniform` (0, no aberration). The range
/// (-1..1) is checked where the camera is built.
pub fn parse_spherical_aberration(text: &str) -> Result<f64, SettingError> {
    match text {
        "uniform" => Ok(0.0),
        _ => text.trim().parse().map_err(SettingError::SphericalAberration),
    }
}

/// An image size `WIDTHxHEIGHT` in pixels, both at least 1.
pub fn parse_size_px(text: &str) -> Result<(u32, u32), SettingError> {
    let size = text.split_once('x').and_then(|(w, h)| Some((w.trim().parse::<u32>().ok()?, h.trim().parse().ok()?)));
    match size {
        Some((width, height)) if width > 0 && height > 0 => Ok((width, height)),
        _ => Err(SettingError::NotASize { text: text.to_string() }),
    }
}

/// A size in bytes (`--max-gpu-memory`): a number with an optional K, M, G or T (powers of
/// 1000, a trailing B allowed) or KiB, MiB, GiB, TiB (powers of 1024).
pub fn parse_bytes(text: &str) -> Result<u64, SettingError> {
    let bad = || SettingError::NotBytes { text: text.to_string() };
    let t = text.trim();
    let split = t.find(|c: char| !(c.is_ascii_digit() || c == '.')).unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let value: f64 = number.parse().map_err(|_| bad())?;
    let unit = unit.trim().to_ascii_uppercase();
    let (unit, base) = match unit.strip_suffix("IB") {
        Some(u) if !u.is_empty() => (u, 1024.0f64),
        _ => (unit.strip_suffix('B').unwrap_or(&unit), 1000.0),
    };
    let power = ["", "K", "M", "G", "T"].iter().position(|u| *u == unit).ok_or_else(bad)?;
    let bytes = value * base.powi(power as i32);
    if !(1.0..1e18).contains(&bytes) {
        return Err(bad());
    }
    Ok(bytes as u64)
}

/// An explicit flare light `X,Y,ENERGY[,AREA]`: its position in pixels (may be outside the
/// frame), its white energy (scene value x pixels) and visible area (pixels, default 1).
pub fn parse_flare_light(text: &str) -> Result<crate::model::flare::FlareLight, SettingError> {
    let bad = || SettingError::NotAFlareLight { text: text.to_string() };
    let numbers: Vec<f64> =
        text.split(',').map(|v| v.trim().parse::<f64>()).collect::<Result<_, _>>().map_err(|_| bad())?;
    let light = match numbers[..] {
        [x, y, e] => crate::model::flare::FlareLight::white(x, y, e),
        [x, y, e, area_px] => {
            crate::model::flare::FlareLight { area_px, ..crate::model::flare::FlareLight::white(x, y, e) }
        }
        _ => return Err(bad()),
    };
    if light.is_valid() {
        Ok(light)
    } else {
        Err(bad())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_in_bytes() {
        assert_eq!(parse_bytes("2G"), Ok(2_000_000_000));
        assert_eq!(parse_bytes("1.5GB"), Ok(1_500_000_000));
        assert_eq!(parse_bytes("512m"), Ok(512_000_000));
        assert_eq!(parse_bytes("2GiB"), Ok(2 * 1024 * 1024 * 1024));
        assert_eq!(parse_bytes("100"), Ok(100));
        assert_eq!(parse_bytes("1 KiB"), Ok(1024));
        for bad in ["", "G", "2X", "0", "0.5", "1e3", "2 GiBs", "-1G", "2000000P", "iB"] {
            assert_eq!(parse_bytes(bad), Err(SettingError::NotBytes { text: bad.to_string() }), "{bad:?}");
        }
        assert_eq!(
            SettingError::NotBytes { text: "2X".into() }.to_string(),
            "\"2X\" is not a size in bytes from 1 byte to below 1 EB: a number with K, M, G or T (powers of 1000, an optional B), or KiB, MiB, GiB, TiB"
        );
    }

    #[test]
    fn flare_lights_as_text() {
        use crate::model::flare::FlareLight;
        assert_eq!(parse_flare_light("-20, 300.5, 1e6"), Ok(FlareLight::white(-20.0, 300.5, 1e6)));
        assert_eq!(parse_flare_light("1,2,3,9").map(|l| l.area_px), Ok(9.0));
        for bad in ["1,2", "1,2,x", "1,2,-5", "1,2,3,4,5", "nan,2,3"] {
            assert_eq!(
                parse_flare_light(bad).unwrap_err().to_string(),
                format!("{bad:?} is not X,Y,ENERGY[,AREA] (pixels; the energy a sum of scene values over pixels, at least 0)")
            );
        }
    }

    #[test]
    fn shutter_times_as_fractions_and_decimals() {
        assert_eq!(parse_shutter_s("1/50"), Ok(0.02));
        assert_eq!(parse_shutter_s(" 1 / 4 "), Ok(0.25));
        assert_eq!(parse_shutter_s("0.02"), Ok(0.02));
        assert_eq!(parse_shutter_s("2"), Ok(2.0));
        for bad in ["0", "-1", "1/0", "0/0", "-1/50", "inf"] {
            assert_eq!(parse_shutter_s(bad), Err(SettingError::NotAPositiveTime), "{bad}");
        }
        for bad in ["abc", "1/abc", "", "1/50/2"] {
            let err = parse_shutter_s(bad).unwrap_err();
            assert!(matches!(err, SettingError::Number(_)), "{bad}: {err:?}");
        }
        assert_eq!(parse_shutter_s("abc").unwrap_err().to_string(), "invalid float literal");
        assert_eq!(SettingError::NotAPositiveTime.to_string(), "must be a positive time in seconds");
    }

    #[test]
    fn spherical_aberration_is_a_number_or_uniform() {
        assert_eq!(parse_spherical_aberration("uniform"), Ok(0.0));
        assert_eq!(parse_spherical_aberration(" -0.5"), Ok(-0.5));
        // Out of range parses; the camera refuses it.
        assert_eq!(parse_spherical_aberration("3"), Ok(3.0));
        let err = parse_spherical_aberration("strong").unwrap_err();
        assert!(matches!(err, SettingError::SphericalAberration(_)));
        assert_eq!(err.to_string(), "a number in [-1, 1] or 'uniform'");
    }

    #[test]
    fn coc_limits_in_pixels_or_on_the_film() {
        use crate::model::camera::CocLimit;
        assert_eq!(parse_coc_limit("64"), Ok(CocLimit::Px(64.0)));
        assert_eq!(parse_coc_limit("none"), Ok(CocLimit::None));
        assert_eq!(parse_coc_limit(" 64px"), Ok(CocLimit::Px(64.0)));
        assert_eq!(parse_coc_limit("1.2mm"), Ok(CocLimit::FilmMm(1.2)));
        assert_eq!(parse_coc_limit("1.2 mm"), Ok(CocLimit::FilmMm(1.2)));
        for bad in ["", "mm", "1.2cm", "big"] {
            assert_eq!(parse_coc_limit(bad), Err(SettingError::NotACocLimit { text: bad.into() }), "{bad}");
        }
    }

    #[test]
    fn image_sizes() {
        assert_eq!(parse_size_px("1920x1080"), Ok((1920, 1080)));
        assert_eq!(parse_size_px(" 64 x 48 "), Ok((64, 48)));
        for bad in ["1920", "0x10", "10x0", "axb", "-1x5", "1920X1080", ""] {
            assert_eq!(parse_size_px(bad), Err(SettingError::NotASize { text: bad.into() }), "{bad}");
        }
        assert_eq!(parse_size_px("abc").unwrap_err().to_string(), "\"abc\" is not WIDTHxHEIGHT");
    }
}
