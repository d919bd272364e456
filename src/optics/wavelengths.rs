//! The wavelength each RGB channel stands for, from the working space's primaries: the
//! chromatic effects (longitudinal and lateral colour, the diffraction patterns) are computed
//! per channel at these wavelengths, so that they fit the space the frame is stored in.
//!
//! A channel's wavelength is its primary's **dominant wavelength** (CIE 15:2004 sec. 9.1): the
//! point of the spectral locus of the CIE 1931 chromaticity diagram on the half-line from the
//! white point through the primary. A primary outside the locus (AP1's green, AP0's) has one
//! too: the half-line crosses the locus between the white and the primary. A half-line that
//! meets the purple line instead takes the nearer end of the locus (AP0's red lies on its red
//! end, 700 nm). Rec.709 gives 611.4, 549.1, 464.2 nm; ACEScg 628.8, 533.0, 467.2 nm.
//!
//! Lens files give longitudinal and lateral colour at the Fraunhofer lines: red = C (656.3
//! nm), blue = F (486.1 nm), both against green = d (587.6 nm). At other wavelengths the
//! value is the parabola through the three lines (zero at d): an achromat's focal shift
//! against wavelength is close to one (its secondary spectrum), and a lens with index linear
//! in wavelength (src/optics/prescription) gives a straight line, which the parabola keeps.

use super::colour::Chromaticities;
use super::prescription::{LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM};

/// The CIE 1931 2-degree observer's spectral locus (chromaticity x, y of each wavelength, nm),
/// 380 to 700 nm every 5 nm, from the CIE 1931 colour-matching functions (ISO/CIE 11664-1:2019):
/// x = xbar / (xbar + ybar + zbar), y likewise. Beyond 700 nm the locus stays within 1e-4.
const SPECTRAL_LOCUS_XY: [(f64, [f64; 2]); 65] = [
    (380.0, [0.174112, 0.004964]),
    (385.0, [0.174008, 0.004981]),
    (390.0, [0.173801, 0.004915]),
    (395.0, [0.173560, 0.004923]),
    (400.0, [0.173337, 0.004797]),
    (405.0, [0.173021, 0.004775]),
    (410.0, [0.172577, 0.004799]),
    (415.0, [0.172087, 0.004833]),
    (420.0, [0.171407, 0.005102]),
    (425.0, [0.170301, 0.005789]),
    (430.0, [0.168878, 0.006900]),
    (435.0, [0.166895, 0.008556]),
    (440.0, [0.164412, 0.010858]),
    (445.0, [0.161105, 0.013793]),
    (450.0, [0.156641, 0.017705]),
    (455.0, [0.150985, 0.022740]),
    (460.0, [0.143960, 0.029703]),
    (465.0, [0.135503, 0.039879]),
    (470.0, [0.124118, 0.057803]),
    (475.0, [0.109594, 0.086843]),
    (480.0, [0.091294, 0.132702]),
    (485.0, [0.068706, 0.200723]),
    (490.0, [0.045391, 0.294976]),
    (495.0, [0.023460, 0.412703]),
    (500.0, [0.008168, 0.538423]),
    (505.0, [0.003859, 0.654823]),
    (510.0, [0.013870, 0.750186]),
    (515.0, [0.038852, 0.812016]),
    (520.0, [0.074302, 0.833803]),
    (525.0, [0.114161, 0.826207]),
    (530.0, [0.154722, 0.805864]),
    (535.0, [0.192876, 0.781629]),
    (540.0, [0.229620, 0.754329]),
    (545.0, [0.265775, 0.724324]),
    (550.0, [0.301604, 0.692308]),
    (555.0, [0.337363, 0.658848]),
    (560.0, [0.373102, 0.624451]),
    (565.0, [0.408736, 0.589607]),
    (570.0, [0.444062, 0.554714]),
    (575.0, [0.478775, 0.520202]),
    (580.0, [0.512486, 0.486591]),
    (585.0, [0.544787, 0.454434]),
    (590.0, [0.575151, 0.424232]),
    (595.0, [0.602933, 0.396497]),
    (600.0, [0.627037, 0.372491]),
    (605.0, [0.648233, 0.351395]),
    (610.0, [0.665764, 0.334011]),
    (615.0, [0.680079, 0.319747]),
    (620.0, [0.691504, 0.308342]),
    (625.0, [0.700606, 0.299301]),
    (630.0, [0.707918, 0.292027]),
    (635.0, [0.714032, 0.285929]),
    (640.0, [0.719033, 0.280935]),
    (645.0, [0.723032, 0.276948]),
    (650.0, [0.725992, 0.274008]),
    (655.0, [0.728272, 0.271728]),
    (660.0, [0.729969, 0.270031]),
    (665.0, [0.731089, 0.268911]),
    (670.0, [0.731993, 0.268007]),
    (675.0, [0.732719, 0.267281]),
    (680.0, [0.733417, 0.266583]),
    (685.0, [0.734047, 0.265953]),
    (690.0, [0.734390, 0.265610]),
    (695.0, [0.734592, 0.265408]),
    (700.0, [0.734690, 0.265310]),
];

/// Representative wavelengths of the red, green and blue channels when a space gives none
/// (a primary at the white point): the fixed ones realcam used before they came from the
/// primaries.
pub const FALLBACK_RGB_NM: [f64; 3] = [650.0, 550.0, 450.0];

/// The dominant wavelength (nm) of `primary` against `white` (CIE 1931 xy); None when the
/// primary is the white point (no direction).
pub fn dominant_wavelength_nm(primary: [f64; 2], white: [f64; 2]) -> Option<f64> {
    let d = [primary[0] - white[0], primary[1] - white[1]];
    if d[0].hypot(d[1]) < 1e-9 || !d.iter().all(|v| v.is_finite()) {
        return None;
    }
    // The half-line white + t d (t > 0) against the segment a + s (b - a), s in [0, 1].
    let crossing = |a: [f64; 2], b: [f64; 2]| -> Option<(f64, f64)> {
        let e = [b[0] - a[0], b[1] - a[1]];
        let det = -d[0] * e[1] + d[1] * e[0];
        if det.abs() < 1e-15 {
            return None;
        }
        let r = [a[0] - white[0], a[1] - white[1]];
        let t = (-r[0] * e[1] + r[1] * e[0]) / det;
        let s = (d[0] * r[1] - d[1] * r[0]) / det;
        (t > 0.0 && (-1e-12..=1.0 + 1e-12).contains(&s)).then_some((t, s))
    };
    let locus = SPECTRAL_LOCUS_XY.windows(2).find_map(|w| {
        let ((l0, a), (l1, b)) = (w[0], w[1]);
        crossing(a, b).map(|(_, s)| l0 + s.clamp(0.0, 1.0) * (l1 - l0))
    });
    locus.or_else(|| {
        // The purple line, from the red end to the blue end: the nearer end.
        let ((blue_nm, blue), (red_nm, red)) = (SPECTRAL_LOCUS_XY[0], SPECTRAL_LOCUS_XY[64]);
        crossing(red, blue).map(|(_, s)| if s < 0.5 { red_nm } else { blue_nm })
    })
}

/// The wavelengths (nm) of the red, green and blue channels of `space`: its primaries'
/// dominant wavelengths ([`FALLBACK_RGB_NM`] for a primary at the white point).
pub fn channel_wavelengths_nm(space: &Chromaticities) -> [f64; 3] {
    let primaries = [space.red, space.green, space.blue];
    [0, 1, 2].map(|c| dominant_wavelength_nm(primaries[c], space.white).unwrap_or(FALLBACK_RGB_NM[c]))
}

/// The weights of a lens file's C-line (red) and F-line (blue) values at `lambda_nm`: the
/// Lagrange parabola through (C, red), (d, 0), (F, blue) is `w[0] red + w[1] blue`.
pub fn fraunhofer_weights(lambda_nm: f64) -> [f64; 2] {
    let (c, d, f) = (LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM);
    [(lambda_nm - d) * (lambda_nm - f) / ((c - d) * (c - f)), (lambda_nm - d) * (lambda_nm - c) / ((f - d) * (f - c))]
}

/// A lens file's chromatic value given at the C line (`red`) and the F line (`blue`), zero at
/// the d line, at the channel wavelengths `nm`: the red and the blue channel's value minus the
/// green channel's. Green stays the reference, as in the lens file: the camera is focused for
/// it, and the distortion table is its.
pub fn channel_values(red: f64, blue: f64, nm: [f64; 3]) -> [f64; 2] {
    let at = |lambda: f64| {
        let [wc, wf] = fraunhofer_weights(lambda);
        wc * red + wf * blue
    };
    let green = at(nm[1]);
    [at(nm[0]) - green, at(nm[2]) - green]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rec.709's and AP1's dominant wavelengths against an independent computation: the same
    /// construction on the CIE 1931 colour-matching functions every 1 nm (colour-science
    /// 0.4.7's copy of the CIE tables, in a scratch Python environment: Rec.709 611.28, 549.13,
    /// 464.31 nm; AP1 628.71, 532.89, 467.46 nm; its own `dominant_wavelength`, to the nearest
    /// nm: 611, 549, 464 and 629, 533, 467). The 5 nm table here is within 0.3 nm of them.
    #[test]
    fn dominant_wavelengths_of_rec709_and_ap1() {
        for (space, want) in
            [(Chromaticities::REC709, [611.28, 549.13, 464.31]), (Chromaticities::ACES_AP1, [628.71, 532.89, 467.46])]
        {
            let got = channel_wavelengths_nm(&space);
            for c in 0..3 {
                assert!((got[c] - want[c]).abs() < 0.3, "{space:?} channel {c}: {got:?} vs {want:?}");
            }
        }
        // By hand: a primary on the locus is its own wavelength (520 nm from the table, seen
        // from D65), and moving it along the same half-line does not change it.
        let (nm, xy) = SPECTRAL_LOCUS_XY[28];
        assert_eq!(nm, 520.0);
        let white = Chromaticities::REC709.white;
        assert!((dominant_wavelength_nm(xy, white).unwrap() - 520.0).abs() < 1e-9);
        let halfway = [0.5 * (xy[0] + white[0]), 0.5 * (xy[1] + white[1])];
        assert!((dominant_wavelength_nm(halfway, white).unwrap() - 520.0).abs() < 1e-9);
        // AP0: red on the locus's red end, green and blue outside it.
        let ap0 = channel_wavelengths_nm(&Chromaticities::ACES_AP0);
        assert!(
            (ap0[0] - 700.0).abs() < 0.5 && (515.0..525.0).contains(&ap0[1]) && (470.0..476.0).contains(&ap0[2]),
            "{ap0:?}"
        );
        // No direction: the fallback.
        assert_eq!(dominant_wavelength_nm(white, white), None);
        let grey = Chromaticities { green: white, ..Chromaticities::REC709 };
        assert_eq!(channel_wavelengths_nm(&grey)[1], 550.0);
    }

    #[test]
    fn the_parabola_goes_through_the_fraunhofer_lines() {
        assert_eq!(fraunhofer_weights(LAMBDA_C_NM), [1.0, 0.0]);
        assert_eq!(fraunhofer_weights(LAMBDA_F_NM), [0.0, 1.0]);
        assert_eq!(fraunhofer_weights(LAMBDA_D_NM), [0.0, 0.0]);
        // Index linear in wavelength: a value linear in wavelength stays on its line, e.g.
        // 0.1 mm per 100 nm from d: red 0.0687, blue -0.1015, at 611.4 nm 0.0238.
        let per_nm = 1e-3;
        let [red, blue] = channel_values(
            per_nm * (LAMBDA_C_NM - LAMBDA_D_NM),
            per_nm * (LAMBDA_F_NM - LAMBDA_D_NM),
            [611.4, 549.1, 464.2],
        );
        assert!((red - per_nm * (611.4 - 549.1)).abs() < 1e-12 && (blue - per_nm * (464.2 - 549.1)).abs() < 1e-12);
        // At the lines themselves the lens file's values come back.
        assert_eq!(channel_values(0.3, 0.2, [LAMBDA_C_NM, LAMBDA_D_NM, LAMBDA_F_NM]), [0.3, 0.2]);
        // An achromat's red 0.4 mm behind green and blue 0.3 mm in front (C and F), by hand at
        // Rec.709's 611.37, 549.14, 464.20 nm: the weights (C, F) are (0.2547, -0.0618),
        // (-0.2074, 0.2386), (0.2311, 1.3721); q = 0.1204, -0.1545, -0.3192 mm; red 0.2749
        // and blue -0.1647 mm from green.
        let [red, blue] = channel_values(0.4, -0.3, [611.37, 549.14, 464.20]);
        assert!((red - 0.2749).abs() < 2e-4 && (blue + 0.1647).abs() < 2e-4, "{red} {blue}");
    }
}
