//! RGB colour spaces as their primaries and white point (CIE 1931 xy): the matrix from RGB to
//! CIE XYZ, the luminance weights (its Y row), and the matrix between two spaces.
//!
//! The normalised primary matrix follows SMPTE RP 177-1993 (sec. 3.3): the columns are the
//! primaries' XYZ (x/y, 1, (1-x-y)/y), each scaled so that RGB (1, 1, 1) is the white point
//! with Y = 1. Between two spaces the XYZ is kept (no chromatic adaptation), so luminance is
//! the same number in both: what a luminance threshold compares does not depend on the space a
//! frame is stored in.

use super::OpticsError;

/// A linear RGB space: the CIE 1931 xy of its red, green and blue primaries and white point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chromaticities {
    pub red: [f64; 2],
    pub green: [f64; 2],
    pub blue: [f64; 2],
    pub white: [f64; 2],
}

/// D65 (ITU-R BT.709 table 1).
const D65: [f64; 2] = [0.3127, 0.3290];
/// The ACES white, about D60 (SMPTE ST 2065-1 sec. 4.1).
const ACES_WHITE: [f64; 2] = [0.32168, 0.33767];

impl Chromaticities {
    /// ITU-R BT.709 (and sRGB) primaries, D65: OpenEXR's default when a file has no
    /// `chromaticities`.
    pub const REC709: Chromaticities =
        Chromaticities { red: [0.64, 0.33], green: [0.30, 0.60], blue: [0.15, 0.06], white: D65 };
    /// ACES AP1 (ACEScg, S-2014-004 sec. 4.1).
    pub const ACES_AP1: Chromaticities =
        Chromaticities { red: [0.713, 0.293], green: [0.165, 0.830], blue: [0.128, 0.044], white: ACES_WHITE };
    /// ACES AP0 (ACES2065-1, SMPTE ST 2065-1 sec. 4.1).
    pub const ACES_AP0: Chromaticities =
        Chromaticities { red: [0.7347, 0.2653], green: [0.0, 1.0], blue: [0.0001, -0.0770], white: ACES_WHITE };
    /// ITU-R BT.2020 primaries, D65.
    pub const REC2020: Chromaticities =
        Chromaticities { red: [0.708, 0.292], green: [0.170, 0.797], blue: [0.131, 0.046], white: D65 };
    /// Display P3 primaries (SMPTE EG 432-1), D65.
    pub const P3_D65: Chromaticities =
        Chromaticities { red: [0.680, 0.320], green: [0.265, 0.690], blue: [0.150, 0.060], white: D65 };

    /// Checked: every coordinate finite, y of each primary and the white non-zero, and the
    /// primaries not on one line (an RGB to XYZ matrix exists).
    pub fn new(red: [f64; 2], green: [f64; 2], blue: [f64; 2], white: [f64; 2]) -> Result<Self, OpticsError> {
        let c = Chromaticities { red, green, blue, white };
        let all = [red, green, blue, white];
        let bad = |why: &str| Err(OpticsError::InvalidChromaticities { chromaticities: all, why: why.to_string() });
        if all.iter().flatten().any(|v| !v.is_finite()) {
            return bad("a coordinate is not finite");
        }
        if all.iter().any(|xy| xy[1] == 0.0) {
            return bad("a y coordinate is 0");
        }
        if c.primaries_xyz_determinant().abs() < 1e-9 {
            return bad("the primaries lie on one line");
        }
        let m = c.rgb_to_xyz();
        if !m.iter().flatten().all(|v| v.is_finite()) {
            return bad("the white point cannot be made of the primaries");
        }
        Ok(c)
    }

    /// The primaries' XYZ with Y = 1, as columns.
    fn primaries_xyz(&self) -> [[f64; 3]; 3] {
        let xyz = |[x, y]: [f64; 2]| [x / y, 1.0, (1.0 - x - y) / y];
        let (r, g, b) = (xyz(self.red), xyz(self.green), xyz(self.blue));
        [[r[0], g[0], b[0]], [r[1], g[1], b[1]], [r[2], g[2], b[2]]]
    }

    fn primaries_xyz_determinant(&self) -> f64 {
        determinant(&self.primaries_xyz())
    }

    /// The normalised primary matrix (SMPTE RP 177-1993 sec. 3.3): XYZ = M RGB, with RGB
    /// (1, 1, 1) at the white point, Y = 1.
    pub fn rgb_to_xyz(&self) -> [[f64; 3]; 3] {
        let p = self.primaries_xyz();
        let [wx, wy] = self.white;
        let white = [wx / wy, 1.0, (1.0 - wx - wy) / wy];
        // The primaries' scales S solve P S = W (RP 177 eq. 3.3.3).
        let s = mul_vec(&inverse(&p), white);
        let mut m = p;
        for row in &mut m {
            for (v, k) in row.iter_mut().zip(s) {
                *v *= k;
            }
        }
        m
    }

    /// The luminance Y of RGB (1, 0, 0), (0, 1, 0) and (0, 0, 1): the Y row of
    /// [`Chromaticities::rgb_to_xyz`]; they sum to 1.
    pub fn luminance_weights(&self) -> [f64; 3] {
        self.rgb_to_xyz()[1]
    }

    /// The matrix taking RGB in `self` to RGB in `to` with the same XYZ.
    pub fn rgb_to(&self, to: &Chromaticities) -> [[f64; 3]; 3] {
        mul(&inverse(&to.rgb_to_xyz()), &self.rgb_to_xyz())
    }

    /// The matrix taking RGB in `self` to RGB in `to` with `self`'s white adapted to `to`'s by
    /// the linearised Bradford transform (ICC.1:2010 annex E.3, eq. E.10-E.12: cone responses
    /// scaled by the ratio of the two whites'), as OpenColorIO's ACES configs convert between
    /// spaces of different whites: RGB (1, 1, 1) stays (1, 1, 1). With equal whites it is
    /// [`Chromaticities::rgb_to`].
    pub fn rgb_to_adapted(&self, to: &Chromaticities) -> [[f64; 3]; 3] {
        let cone = |[x, y]: [f64; 2]| mul_vec(&BRADFORD, [x / y, 1.0, (1.0 - x - y) / y]);
        let (src, dst) = (cone(self.white), cone(to.white));
        let scale = [[dst[0] / src[0], 0.0, 0.0], [0.0, dst[1] / src[1], 0.0], [0.0, 0.0, dst[2] / src[2]]];
        let adapt = mul(&inverse(&BRADFORD), &mul(&scale, &BRADFORD));
        mul(&inverse(&to.rgb_to_xyz()), &mul(&adapt, &self.rgb_to_xyz()))
    }
}

/// A colour space by name: realcam's short names and the names of the ACES configs of
/// OpenColorIO (case and the characters ` -_.()` ignored); None for a name it does not know.
pub fn named_space(name: &str) -> Option<(&'static str, Chromaticities)> {
    let key: String = name.chars().filter(|c| c.is_ascii_alphanumeric()).map(|c| c.to_ascii_lowercase()).collect();
    NAMED_SPACES
        .iter()
        .find(|(_, aliases, _)| aliases.contains(&key.as_str()))
        .map(|(canonical, _, c)| (*canonical, *c))
}

/// The name of the known space `c` is, within 1e-6 in every coordinate (a file stores them as
/// 32-bit floats).
pub fn space_name(c: &Chromaticities) -> Option<&'static str> {
    let a = [c.red, c.green, c.blue, c.white];
    NAMED_SPACES
        .iter()
        .find(|(_, _, k)| {
            let k = [k.red, k.green, k.blue, k.white];
            a.iter().flatten().zip(k.iter().flatten()).all(|(x, y)| (x - y).abs() <= 1e-6)
        })
        .map(|(name, _, _)| *name)
}

/// The spaces [`named_space`] knows: the canonical name (as the ACES configs of OpenColorIO
/// call it), the keys it matches, its chromaticities.
pub const NAMED_SPACES: [(&str, &[&str], Chromaticities); 5] = [
    (
        "Linear Rec.709 (sRGB)",
        &["linearrec709srgb", "linrec709", "linearrec709", "linsrgb", "linearsrgb", "scenelinearrec709srgb", "rec709"],
        Chromaticities::REC709,
    ),
    ("ACEScg", &["acescg", "ap1", "linap1", "acesap1"], Chromaticities::ACES_AP1),
    ("ACES2065-1", &["aces20651", "ap0", "linap0", "acesap0", "aces"], Chromaticities::ACES_AP0),
    ("Linear Rec.2020", &["linearrec2020", "linrec2020", "rec2020"], Chromaticities::REC2020),
    ("Linear P3-D65", &["linearp3d65", "linp3d65", "p3d65"], Chromaticities::P3_D65),
];

/// The sRGB OETF (IEC 61966-2-1 sec. 5.2, eq. 5): a linear value in [0, 1] encoded for an
/// sRGB display. In f32: the preview's pixels are f32.
pub fn srgb_oetf(v: f32) -> f32 {
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

/// The Bradford cone response matrix, XYZ to the sharpened LMS (ICC.1:2010 annex E.3).
const BRADFORD: [[f64; 3]; 3] = [[0.8951, 0.2664, -0.1614], [-0.7502, 1.7135, 0.0367], [0.0389, -0.0685, 1.0296]];

fn determinant(m: &[[f64; 3]; 3]) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// The inverse by cofactors (the callers' matrices are checked to be regular).
fn inverse(m: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let d = determinant(m);
    let c = |r0: usize, c0: usize, r1: usize, c1: usize| m[r0][c0] * m[r1][c1] - m[r0][c1] * m[r1][c0];
    [
        [c(1, 1, 2, 2) / d, -c(0, 1, 2, 2) / d, c(0, 1, 1, 2) / d],
        [-c(1, 0, 2, 2) / d, c(0, 0, 2, 2) / d, -c(0, 0, 1, 2) / d],
        [c(1, 0, 2, 1) / d, -c(0, 0, 2, 1) / d, c(0, 0, 1, 1) / d],
    ]
}

fn mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut m = [[0.0; 3]; 3];
    for (i, row) in m.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    m
}

/// `m` times the column `v`.
pub fn mul_vec(m: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [0, 1, 2].map(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 3], b: [f64; 3], tol: f64) -> bool {
        a.iter().zip(b).all(|(x, y)| (x - y).abs() <= tol)
    }

    #[test]
    fn luminance_weights_match_the_published_ones() {
        // ITU-R BT.709-6 item 3.2 (to four places).
        let rec709 = Chromaticities::REC709.luminance_weights();
        assert!(close(rec709, [0.2126, 0.7152, 0.0722], 5e-5), "{rec709:?}");
        // AP1's normalised primary matrix, row Y (ACES TB-2014-004, S-2014-004).
        let ap1 = Chromaticities::ACES_AP1.luminance_weights();
        assert!(close(ap1, [0.2722287168, 0.6740817658, 0.0536895174], 1e-9), "{ap1:?}");
        // AP0's (SMPTE ST 2065-1 sec. 4.1: 0.3439664498, 0.7281660966, -0.0721325464).
        let ap0 = Chromaticities::ACES_AP0.luminance_weights();
        assert!(close(ap0, [0.3439664498, 0.7281660966, -0.0721325464], 1e-9), "{ap0:?}");
        // BT.2020-2 table 4: 0.2627, 0.6780, 0.0593.
        let rec2020 = Chromaticities::REC2020.luminance_weights();
        assert!(close(rec2020, [0.2627, 0.6780, 0.0593], 5e-5), "{rec2020:?}");
        for c in [Chromaticities::REC709, Chromaticities::ACES_AP1, Chromaticities::ACES_AP0, Chromaticities::P3_D65] {
            assert!((c.luminance_weights().iter().sum::<f64>() - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn conversions_keep_xyz_and_invert() {
        let to_709 = Chromaticities::ACES_AP1.rgb_to(&Chromaticities::REC709);
        let back = Chromaticities::REC709.rgb_to(&Chromaticities::ACES_AP1);
        let rgb = [0.3, 2.5, 0.01];
        let there = mul_vec(&to_709, rgb);
        assert!(close(mul_vec(&back, there), rgb, 1e-12));
        let xyz = |c: &Chromaticities, v| mul_vec(&c.rgb_to_xyz(), v);
        assert!(close(xyz(&Chromaticities::ACES_AP1, rgb), xyz(&Chromaticities::REC709, there), 1e-12));
        // The white of one space is not the other's: AP1's (1, 1, 1) is D60, a little warm in Rec.709.
        let white = mul_vec(&to_709, [1.0; 3]);
        assert!(white[0] > 1.0 && white[2] < 1.0, "{white:?}");
    }

    #[test]
    fn names_and_bad_chromaticities() {
        assert_eq!(named_space("acescg").map(|s| s.0), Some("ACEScg"));
        assert_eq!(named_space("Linear Rec.709 (sRGB)").map(|s| s.1), Some(Chromaticities::REC709));
        assert_eq!(named_space("lin_rec709").map(|s| s.0), Some("Linear Rec.709 (sRGB)"));
        assert_eq!(named_space("ACES2065-1").map(|s| s.1), Some(Chromaticities::ACES_AP0));
        assert_eq!(named_space("sRGB - Texture"), None);
        // As a file stores them (f32).
        let ap1 = Chromaticities::ACES_AP1;
        let stored = |[x, y]: [f64; 2]| [f64::from(x as f32), f64::from(y as f32)];
        let from_file = Chromaticities::new(stored(ap1.red), stored(ap1.green), stored(ap1.blue), stored(ap1.white));
        assert_ne!(from_file, Ok(ap1));
        assert_eq!(space_name(&from_file.unwrap()), Some("ACEScg"));
        assert_eq!(space_name(&Chromaticities { white: [0.3, 0.3], ..ap1 }), None);
        let c = Chromaticities::REC709;
        assert_eq!(Chromaticities::new(c.red, c.green, c.blue, c.white), Ok(c));
        let err = Chromaticities::new(c.red, c.red, c.blue, c.white).unwrap_err();
        assert!(err.to_string().ends_with("the primaries lie on one line"), "{err}");
        let err = Chromaticities::new(c.red, [0.3, 0.0], c.blue, c.white).unwrap_err();
        assert!(err.to_string().ends_with("a y coordinate is 0"), "{err}");
        let err = Chromaticities::new(c.red, c.green, [f64::NAN, 0.1], c.white).unwrap_err();
        assert!(err.to_string().ends_with("a coordinate is not finite"), "{err}");
    }
}
