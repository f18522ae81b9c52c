//! CIE 1931 2° tristimulus values and chromaticities.
//!
//! Spectra are `&[f64]` on the observer's [`WavelengthGrid`]. Sums follow CIE 015:2018:
//! `X = k·Σ S(λ)·R(λ)·x̄(λ)·Δλ` (likewise Y, Z) with `k = 100 / Σ S(λ)·ȳ(λ)·Δλ`, so the perfect
//! white under any illuminant has Y = 100. Δλ are the grid's quadrature weights
//! ([`WavelengthGrid::weights_nm`]; the step on a uniform grid). For self-luminous stimuli
//! [`CieObserver::xyz_of_radiance`] returns the unnormalised `Σ L(λ)·x̄(λ)·Δλ` (no 683 lm/W).

use crate::data;
use crate::error::Result;
use crate::grid::WavelengthGrid;

/// The CIE 1931 2° colour-matching functions resampled on a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct CieObserver {
    grid: WavelengthGrid,
    /// x̄, ȳ, z̄ on the grid.
    cmfs: [Vec<f64>; 3],
    weights_nm: Vec<f64>,
}

impl CieObserver {
    /// The CIE 1931 2° observer on `grid` (linear resampling of the 1 nm table). Error if the
    /// grid leaves 360–830 nm.
    pub fn cie1931(grid: &WavelengthGrid) -> Result<Self> {
        let t = data::cie1931_xyz().resample(grid)?;
        let [x, y, z]: [Vec<f64>; 3] = t.values.try_into().expect("three CMF columns");
        Ok(CieObserver {
            grid: grid.clone(),
            cmfs: [x, y, z],
            weights_nm: grid.weights_nm(),
        })
    }

    /// The grid.
    pub fn grid(&self) -> &WavelengthGrid {
        &self.grid
    }

    /// x̄ (0), ȳ (1) or z̄ (2) on the grid.
    pub fn cmf(&self, channel: usize) -> &[f64] {
        &self.cmfs[channel]
    }

    /// CMFs as a row-major `(grid.len() × 3)` matrix (rows = wavelengths), for projecting
    /// spectral images.
    pub fn cmf_matrix(&self) -> Vec<f64> {
        (0..self.grid.len())
            .flat_map(|i| [self.cmfs[0][i], self.cmfs[1][i], self.cmfs[2][i]])
            .collect()
    }

    /// `Σ L(λ)·[x̄ ȳ z̄](λ)·Δλ` of a radiance spectrum, unnormalised.
    ///
    /// # Panics
    /// If the spectrum length differs from the grid's.
    pub fn xyz_of_radiance(&self, radiance: &[f64]) -> [f64; 3] {
        self.check(radiance, "radiance");
        let mut out = [0.0; 3];
        for (i, (&l, &w)) in radiance.iter().zip(&self.weights_nm).enumerate() {
            let lw = l * w;
            for (c, o) in out.iter_mut().enumerate() {
                *o += lw * self.cmfs[c][i];
            }
        }
        out
    }

    /// Tristimulus values of a reflectance under an illuminant, white Y = 100 (CIE 015).
    ///
    /// # Panics
    /// If a spectrum length differs from the grid's.
    pub fn xyz_of_reflectance(&self, reflectance: &[f64], illuminant: &[f64]) -> [f64; 3] {
        self.check(reflectance, "reflectance");
        self.check(illuminant, "illuminant");
        let k = 100.0 / self.xyz_of_radiance(illuminant)[1];
        let mut out = [0.0; 3];
        for i in 0..self.grid.len() {
            let s = illuminant[i] * reflectance[i] * self.weights_nm[i];
            for (c, o) in out.iter_mut().enumerate() {
                *o += s * self.cmfs[c][i];
            }
        }
        out.map(|v| v * k)
    }

    /// White point of an illuminant (perfect reflector), Y = 100.
    pub fn white_xyz(&self, illuminant: &[f64]) -> [f64; 3] {
        self.xyz_of_reflectance(&vec![1.0; self.grid.len()], illuminant)
    }

    fn check(&self, s: &[f64], what: &str) {
        assert_eq!(
            s.len(),
            self.grid.len(),
            "CieObserver: {what} has {} samples, grid has {}",
            s.len(),
            self.grid.len()
        );
    }
}

/// Chromaticity (x, y) of XYZ; (0, 0) for black.
pub fn xyz_to_xy(xyz: [f64; 3]) -> [f64; 2] {
    let s = xyz[0] + xyz[1] + xyz[2];
    if s == 0.0 {
        [0.0, 0.0]
    } else {
        [xyz[0] / s, xyz[1] / s]
    }
}

/// XYZ → (x, y, Y).
pub fn xyz_to_xyy(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y] = xyz_to_xy(xyz);
    [x, y, xyz[1]]
}

/// (x, y, Y) → XYZ; black when y = 0.
pub fn xyy_to_xyz(xyy: [f64; 3]) -> [f64; 3] {
    let [x, y, big_y] = xyy;
    if y == 0.0 {
        return [0.0, 0.0, 0.0];
    }
    [x * big_y / y, big_y, (1.0 - x - y) * big_y / y]
}

/// CIE 1976 L\*a\*b\* of `xyz` relative to the reference white `white_xyz` (CIE 15:2004 §8.2.1):
/// `L* = 116 f(Y/Yn) − 16`, `a* = 500 (f(X/Xn) − f(Y/Yn))`, `b* = 200 (f(Y/Yn) − f(Z/Zn))`,
/// `f(t) = t^(1/3)` above `(6/29)³`, else `t / (3 (6/29)²) + 4/29`. Hue angle
/// `h_ab = atan2(b*, a*)`: 0° reddish-pink, 90° yellow, 180° green-teal, 270° blue.
pub fn xyz_to_lab(xyz: [f64; 3], white_xyz: [f64; 3]) -> [f64; 3] {
    let delta: f64 = 6.0 / 29.0;
    let f = |t: f64| {
        if t > delta.powi(3) {
            t.cbrt()
        } else {
            t / (3.0 * delta * delta) + 4.0 / 29.0
        }
    };
    let [fx, fy, fz] = [0, 1, 2].map(|i| f(xyz[i] / white_xyz[i]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// The Bradford cone-response matrix (Lam 1985; ICC v4 Annex E, ISO 22028).
pub const BRADFORD: [[f64; 3]; 3] = [
    [0.8951, 0.2664, -0.1614],
    [-0.7502, 1.7135, 0.0367],
    [0.0389, -0.0685, 1.0296],
];

/// Von Kries chromatic adaptation in the Bradford space of `xyz` seen under white `from_white`
/// to the corresponding colour under `to_white` (all XYZ on the same scale).
pub fn bradford_adapt(xyz: [f64; 3], from_white: [f64; 3], to_white: [f64; 3]) -> [f64; 3] {
    use crate::linalg::{mat3_inverse, mat3_vec};
    let s = mat3_vec(&BRADFORD, from_white);
    let d = mat3_vec(&BRADFORD, to_white);
    let c = mat3_vec(&BRADFORD, xyz);
    let adapted = [c[0] * d[0] / s[0], c[1] * d[1] / s[1], c[2] * d[2] / s[2]];
    mat3_vec(
        &mat3_inverse(&BRADFORD).expect("Bradford is invertible"),
        adapted,
    )
}

/// A CIE D-series daylight spectrum of correlated colour temperature `cct_k` (4000–25000 K)
/// from the S0/S1/S2 basis (CIE 015:2018 §4.1), resampled on `grid` (error outside 300–830 nm).
/// Uses the CIE formula for the chromaticity x_D(T) and y_D = −3x² + 2.87x − 0.275.
pub fn daylight_spectrum(cct_k: f64, grid: &WavelengthGrid) -> Result<Vec<f64>> {
    if !(4000.0..=25000.0).contains(&cct_k) {
        return Err(crate::ColorimetryError::setting(
            "cct_k",
            format!("{cct_k} K is outside the D-series range 4000–25000 K"),
        ));
    }
    let t = cct_k;
    let xd = if t <= 7000.0 {
        -4.6070e9 / t.powi(3) + 2.9678e6 / t.powi(2) + 0.09911e3 / t + 0.244063
    } else {
        -2.0064e9 / t.powi(3) + 1.9018e6 / t.powi(2) + 0.24748e3 / t + 0.237040
    };
    let yd = -3.0 * xd * xd + 2.87 * xd - 0.275;
    let m = 0.0241 + 0.2562 * xd - 0.7341 * yd;
    let m1 = (-1.3515 - 1.7703 * xd + 5.9114 * yd) / m;
    let m2 = (0.0300 - 31.4424 * xd + 30.0717 * yd) / m;
    daylight_from_coefficients(m1, m2, grid)
}

/// `S0 + m1·S1 + m2·S2` on `grid` (the daylight basis, linear resampling).
pub fn daylight_from_coefficients(m1: f64, m2: f64, grid: &WavelengthGrid) -> Result<Vec<f64>> {
    let b = data::daylight_basis().resample(grid)?;
    Ok((0..grid.len())
        .map(|i| b.values[0][i] + m1 * b.values[1][i] + m2 * b.values[2][i])
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_1nm_full() -> WavelengthGrid {
        WavelengthGrid::range(360.0, 830.0, 1.0).unwrap()
    }

    #[test]
    fn lab_of_the_white_is_neutral_and_srgb_primaries_match_published_values() {
        let white = [95.047, 100.0, 108.883];
        let lab = xyz_to_lab(white, white);
        assert!((lab[0] - 100.0).abs() < 1e-12 && lab[1].abs() < 1e-12 && lab[2].abs() < 1e-12);
        // sRGB red and blue (IEC 61966-2-1 primaries, D65): L*a*b* 53.24/80.09/67.20 and
        // 32.30/79.19/−107.86 (CIE 15 formula; values as tabulated by Lindbloom).
        for (rgb, want) in [
            ([1.0, 0.0, 0.0], [53.24, 80.09, 67.20]),
            ([0.0, 0.0, 1.0], [32.30, 79.19, -107.86]),
        ] {
            let xyz = crate::srgb::linear_srgb_to_xyz(rgb).map(|v| v * 100.0);
            let lab = xyz_to_lab(xyz, white);
            for c in 0..3 {
                assert!(
                    (lab[c] - want[c]).abs() < 0.02,
                    "{rgb:?}: {lab:?} vs {want:?}"
                );
            }
        }
        // Below the cube-root knee the linear segment is continuous with it.
        let knee = (6.0f64 / 29.0).powi(3);
        let lo = xyz_to_lab([knee * 0.999999; 3], [1.0; 3])[0];
        let hi = xyz_to_lab([knee * 1.000001; 3], [1.0; 3])[0];
        assert!((hi - lo).abs() < 1e-4, "{lo} vs {hi}");
    }

    #[test]
    fn d65_white_is_95_047_100_108_883() {
        // data/README.md and docs/references.md#colorimetry-formulas: 1 nm tables, 360–830 nm.
        let g = grid_1nm_full();
        let obs = CieObserver::cie1931(&g).unwrap();
        let d65 = data::d65().column_on("D65", &g).unwrap();
        let w = obs.white_xyz(&d65);
        for (got, want) in w.iter().zip([95.047, 100.0, 108.883]) {
            assert!((got - want).abs() < 5e-4, "D65 white {w:?}");
        }
        let a = data::illuminant_a().column_on("A", &g).unwrap();
        let wa = obs.white_xyz(&a);
        for (got, want) in wa.iter().zip([109.850, 100.0, 35.585]) {
            assert!((got - want).abs() < 5e-4, "A white {wa:?}");
        }
    }

    #[test]
    fn ohta_neutrals_under_d65_have_tabulated_y() {
        // data/README.md sanity table: Y = 88.7 / 58.4 / 35.8 / 20.3 / 9.3 / 3.4 (1 decimal).
        let t = data::colorchecker_ohta();
        let g = t.grid();
        let obs = CieObserver::cie1931(&g).unwrap();
        let d65 = data::d65().column_on("D65", &g).unwrap();
        let want = [88.7, 58.4, 35.8, 20.3, 9.3, 3.4];
        for (i, w) in want.iter().enumerate() {
            let y = obs.xyz_of_reflectance(&t.values[18 + i], &d65)[1];
            assert!((y - w).abs() <= 0.05 + 1e-9, "patch {}: Y {y}", 19 + i);
        }
    }

    #[test]
    fn bradford_maps_white_to_white_and_is_identity_for_equal_whites() {
        let d50 = [0.9642, 1.0, 0.8249];
        let d65 = [0.95047, 1.0, 1.08883];
        let w = bradford_adapt(d50, d50, d65);
        assert!(
            w.iter().zip(d65).all(|(a, b)| (a - b).abs() < 1e-12),
            "{w:?}"
        );
        let c = [0.3, 0.2, 0.1];
        let same = bradford_adapt(c, d65, d65);
        assert!(same.iter().zip(c).all(|(a, b)| (a - b).abs() < 1e-12));
    }

    #[test]
    fn chromaticity_round_trip_and_d65_xy() {
        let xyz = [41.24, 21.26, 1.93];
        let back = xyy_to_xyz(xyz_to_xyy(xyz));
        for (a, b) in xyz.iter().zip(back) {
            assert!((a - b).abs() < 1e-12);
        }
        let d65 = daylight_spectrum(6504.0, &WavelengthGrid::range(360.0, 830.0, 5.0).unwrap());
        let g = WavelengthGrid::range(360.0, 830.0, 5.0).unwrap();
        let obs = CieObserver::cie1931(&g).unwrap();
        let xy = xyz_to_xy(obs.white_xyz(&d65.unwrap()));
        // D65 chromaticity (0.3127, 0.3290), srgb_constants.csv
        assert!(
            (xy[0] - 0.3127).abs() < 5e-4 && (xy[1] - 0.3290).abs() < 5e-4,
            "{xy:?}"
        );
        assert!(daylight_spectrum(1000.0, &g).is_err());
    }

    /// BabelColor's published chart values (xyY under ICC D50, 4 decimals): BabelColor (2012),
    /// "ColorChecker RGB and spectra", as shipped in colour-science
    /// `CCS_COLOURCHECKERS["BabelColor Average"]`; patches in chart order 1–24.
    const BABELCOLOR_AVERAGE_XYY_D50: [[f64; 3]; 24] = [
        [0.4325, 0.3788, 0.1034],
        [0.4191, 0.3748, 0.3525],
        [0.2761, 0.3004, 0.1847],
        [0.3700, 0.4501, 0.1335],
        [0.3020, 0.2877, 0.2324],
        [0.2856, 0.3910, 0.4174],
        [0.5291, 0.4075, 0.3117],
        [0.2339, 0.2155, 0.1140],
        [0.5008, 0.3293, 0.1979],
        [0.3326, 0.2556, 0.0644],
        [0.3989, 0.4998, 0.4435],
        [0.4962, 0.4428, 0.4358],
        [0.2040, 0.1696, 0.0579],
        [0.3270, 0.5033, 0.2307],
        [0.5709, 0.3298, 0.1268],
        [0.4694, 0.4732, 0.6081],
        [0.4177, 0.2704, 0.2007],
        [0.2151, 0.3037, 0.1903],
        [0.3488, 0.3628, 0.9129],
        [0.3451, 0.3596, 0.5885],
        [0.3446, 0.3590, 0.3595],
        [0.3438, 0.3589, 0.1912],
        [0.3423, 0.3576, 0.0893],
        [0.3439, 0.3565, 0.0320],
    ];

    #[test]
    fn colorchecker_spectra_reproduce_babelcolor_published_chart_values() {
        // The BabelColor average reflectances (10 nm, as published) under CIE D50 through the
        // 1931 observer, to CIELAB against ICC D50, compared with BabelColor's own xyY. The
        // residual comes from their ASTM E308 weighting tables (we sample the CMFs at 10 nm)
        // and the 4-decimal rounding; measured: max ΔE*ab 0.15, median 0.04. A quarter of a
        // just-noticeable difference (ΔE*ab ≈ 1) bounds it; D65 in place of D50 misses by
        // 1.8–3.2 ΔE*ab on patches 1–3 alone.
        let t = data::colorchecker_babelcolor();
        let g = t.grid();
        let obs = CieObserver::cie1931(&g).unwrap();
        let d50 = data::d50().column_on("D50", &g).unwrap();
        let icc_d50 = xyy_to_xyz([0.3457, 0.3585, 1.0]);
        let own_white = obs.white_xyz(&d50).map(|v| v / 100.0);
        let mut worst = (0.0f64, 0);
        for (i, published) in BABELCOLOR_AVERAGE_XYY_D50.iter().enumerate() {
            let xyz = obs
                .xyz_of_reflectance(&t.values[i], &d50)
                .map(|v| v / 100.0);
            let ours = xyz_to_lab(xyz, own_white);
            let theirs = xyz_to_lab(xyy_to_xyz(*published), icc_d50);
            let de = ours
                .iter()
                .zip(theirs)
                .map(|(a, b)| (a - b) * (a - b))
                .sum::<f64>()
                .sqrt();
            if de > worst.0 {
                worst = (de, i + 1);
            }
        }
        assert!(
            worst.0 < 0.25,
            "patch {}: ΔE*ab {:.3} from BabelColor's published value",
            worst.1,
            worst.0
        );
    }
}
