//! Distortion and lateral colour from tables against image height (Kyaw 2013 sec 6.3.5, eq 6.8;
//! sec 6.4 for the per-wavelength part): a point whose ideal (distortion-free) image height is r
//! lands at the real height R = r (1 + D(r)/100), with D in percent interpolated linearly in r
//! from the table. Lateral colour is the extra distortion of the red and blue images relative to
//! green (the d line).

/// A quantity tabulated against image height (mm from the optical centre on the film).
#[derive(Clone, Debug, PartialEq)]
pub struct HeightTable {
    pub image_height_mm: Vec<f64>,
    pub values: Vec<f64>,
}

impl HeightTable {
    /// Linear interpolation; the end values continue beyond the table.
    pub fn at(&self, height_mm: f64) -> f64 {
        let (h, v) = (&self.image_height_mm, &self.values);
        if h.is_empty() {
            return 0.0;
        }
        if height_mm <= h[0] {
            return v[0];
        }
        for i in 1..h.len() {
            if height_mm <= h[i] {
                let t = (height_mm - h[i - 1]) / (h[i] - h[i - 1]);
                return v[i - 1] + t * (v[i] - v[i - 1]);
            }
        }
        v[v.len() - 1]
    }

    pub fn is_zero(&self) -> bool {
        self.values.iter().all(|&v| v == 0.0)
    }

    pub fn max_abs(&self) -> f64 {
        self.values.iter().fold(0.0, |m, v| m.max(v.abs()))
    }

    /// Largest |value| at heights up to `max_height_mm` (the frame's farthest corner): the
    /// table's entries below it and the interpolated value at it.
    pub fn max_abs_within(&self, max_height_mm: f64) -> f64 {
        self.image_height_mm
            .iter()
            .zip(&self.values)
            .filter(|(h, _)| **h <= max_height_mm)
            .fold(self.at(max_height_mm).abs(), |m, (_, v)| m.max(v.abs()))
    }
}

/// Distortion of the green (reference) image and the extra distortion of red and blue, percent.
#[derive(Clone, Debug, PartialEq)]
pub struct DistortionTables {
    pub green_percent: HeightTable,
    pub red_extra_percent: HeightTable,
    pub blue_extra_percent: HeightTable,
}

impl DistortionTables {
    /// Distortion in percent of channel 0 (R), 1 (G) or 2 (B) at ideal height `r_mm`.
    pub fn percent(&self, channel: usize, r_mm: f64) -> f64 {
        let g = self.green_percent.at(r_mm);
        match channel {
            0 => g + self.red_extra_percent.at(r_mm),
            2 => g + self.blue_extra_percent.at(r_mm),
            _ => g,
        }
    }

    /// Kyaw 2013 eq 6.8 forward: the real height of an ideal height.
    pub fn real_height_mm(&self, channel: usize, ideal_mm: f64) -> f64 {
        ideal_mm * (1.0 + self.percent(channel, ideal_mm) / 100.0)
    }

    /// The inverse: the ideal height whose image lands at `real_mm` (fixed-point iteration, which
    /// converges for the few-percent distortions of photographic lenses).
    pub fn ideal_height_mm(&self, channel: usize, real_mm: f64) -> f64 {
        let mut r = real_mm;
        for _ in 0..12 {
            r = real_mm / (1.0 + self.percent(channel, r) / 100.0);
        }
        r
    }

    /// The tables at the channel wavelengths `nm` (R, G, B) instead of the lens file's lines
    /// (red C, blue F, against green): at each height, red's and blue's extra against the green
    /// channel from the parabola through the three lines
    /// ([`crate::optics::wavelengths::channel_values`]); green's table stays (the reference).
    pub fn at_wavelengths(&self, nm: [f64; 3]) -> DistortionTables {
        let heights = &self.green_percent.image_height_mm;
        let extra: Vec<[f64; 2]> = heights
            .iter()
            .map(|&h| {
                crate::optics::wavelengths::channel_values(
                    self.red_extra_percent.at(h),
                    self.blue_extra_percent.at(h),
                    nm,
                )
            })
            .collect();
        let table =
            |c: usize| HeightTable { image_height_mm: heights.clone(), values: extra.iter().map(|e| e[c]).collect() };
        DistortionTables {
            green_percent: self.green_percent.clone(),
            red_extra_percent: table(0),
            blue_extra_percent: table(1),
        }
    }

    pub fn is_zero(&self) -> bool {
        self.green_percent.is_zero() && self.red_extra_percent.is_zero() && self.blue_extra_percent.is_zero()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(v: &[f64]) -> HeightTable {
        HeightTable { image_height_mm: (0..v.len()).map(|i| i as f64 * 5.0).collect(), values: v.to_vec() }
    }

    #[test]
    fn interpolates_and_clamps() {
        let t = table(&[0.0, -1.0, -3.0]);
        assert_eq!(t.at(2.5), -0.5);
        assert_eq!(t.at(7.5), -2.0);
        assert_eq!(t.at(50.0), -3.0);
    }

    #[test]
    fn eq_6_8_round_trip_and_sign() {
        let d = DistortionTables {
            green_percent: table(&[0.0, -1.0, -3.0, -6.0]),
            red_extra_percent: table(&[0.0, 0.1, 0.2, 0.3]),
            blue_extra_percent: table(&[0.0, -0.1, -0.2, -0.3]),
        };
        for c in 0..3 {
            for r in [0.0, 1.0, 7.0, 14.9] {
                let real = d.real_height_mm(c, r);
                assert!((d.ideal_height_mm(c, real) - r).abs() < 1e-9, "channel {c} r {r}");
            }
        }
        // Barrel (negative D): the real image is nearer the centre; eq 6.8 D = 100 (R - r) / r.
        let r = 10.0;
        let real = d.real_height_mm(1, r);
        assert!(real < r);
        assert!((100.0 * (real - r) / r - (-3.0)).abs() < 1e-12);
        // Red is magnified relative to green by its extra 0.2%.
        assert!((d.real_height_mm(0, r) - real - r * 0.002).abs() < 1e-12);
    }
}
