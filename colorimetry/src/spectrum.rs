//! Spectrum utilities on wavelength grids: resampling, products, integration, normalisation,
//! Planck radiators and CIE illuminant A.
//!
//! Spectra are `&[f64]` with one value per grid wavelength (nm); all functions are pure.

use crate::error::{ColorimetryError, Result};
use crate::grid::WavelengthGrid;
use crate::table::interp_linear;

/// Second radiation constant used by CIE illuminant A, nm·K (CIE 015:2018).
pub const CIE_A_C2_NM_K: f64 = 1.435e7;
/// Temperature of CIE illuminant A with c2 = 1.435e7 nm·K, K (equivalent to 2856 K with the
/// modern c2 = 1.4388e7 nm·K).
pub const CIE_A_TEMPERATURE_K: f64 = 2848.0;

/// Resample `(wavelengths_nm, values)` linearly on `grid`. Error if the grid leaves the range.
pub fn resample(wavelengths_nm: &[f64], values: &[f64], grid: &WavelengthGrid) -> Result<Vec<f64>> {
    assert_eq!(
        wavelengths_nm.len(),
        values.len(),
        "spectrum::resample: {} wavelengths vs {} values",
        wavelengths_nm.len(),
        values.len()
    );
    let (lo, hi) = (wavelengths_nm[0], wavelengths_nm[wavelengths_nm.len() - 1]);
    if grid.min_nm() < lo - 1e-9 || grid.max_nm() > hi + 1e-9 {
        return Err(ColorimetryError::NotCovered {
            table: "spectrum".into(),
            table_min_nm: lo,
            table_max_nm: hi,
            requested_min_nm: grid.min_nm(),
            requested_max_nm: grid.max_nm(),
        });
    }
    Ok(grid
        .as_slice()
        .iter()
        .map(|&w| interp_linear(wavelengths_nm, values, w))
        .collect())
}

/// Element-wise product, e.g. reflectance × illuminant = reflected radiance.
pub fn multiply(a: &[f64], b: &[f64]) -> Vec<f64> {
    assert_eq!(
        a.len(),
        b.len(),
        "spectrum::multiply: lengths {} and {}",
        a.len(),
        b.len()
    );
    a.iter().zip(b).map(|(x, y)| x * y).collect()
}

/// `∫ s dλ` with the grid's quadrature weights ([`WavelengthGrid::weights_nm`]).
pub fn integrate(grid: &WavelengthGrid, s: &[f64]) -> f64 {
    assert_eq!(
        s.len(),
        grid.len(),
        "spectrum::integrate: {} values vs grid {}",
        s.len(),
        grid.len()
    );
    s.iter().zip(grid.weights_nm()).map(|(v, w)| v * w).sum()
}

/// Divide by the maximum (no-op for an all-zero spectrum).
pub fn normalise_peak(s: &mut [f64]) {
    let m = s.iter().copied().fold(0.0, f64::max);
    if m > 0.0 {
        s.iter_mut().for_each(|v| *v /= m);
    }
}

/// Relative spectral radiance of a Planck radiator at `temperature_k`, `λ^−5 / (exp(c2/λT) − 1)`
/// with the CIE c2 = 1.4388e7 nm·K (CODATA), normalised to 100 at 560 nm.
pub fn planck_relative(temperature_k: f64, grid: &WavelengthGrid) -> Vec<f64> {
    planck_with_c2(temperature_k, 1.4388e7, grid)
}

fn planck_with_c2(t: f64, c2: f64, grid: &WavelengthGrid) -> Vec<f64> {
    let f = |w: f64| w.powi(-5) / ((c2 / (w * t)).exp() - 1.0);
    let r = f(560.0);
    grid.as_slice().iter().map(|&w| 100.0 * f(w) / r).collect()
}

/// CIE illuminant A from its formula (CIE 015:2018): Planck with c2 = 1.435e7 nm·K at 2848 K,
/// 100 at 560 nm.
pub fn illuminant_a_formula(grid: &WavelengthGrid) -> Vec<f64> {
    planck_with_c2(CIE_A_TEMPERATURE_K, CIE_A_C2_NM_K, grid)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data;

    #[test]
    fn illuminant_a_formula_matches_the_table() {
        // relative error < 5e-6
        let t = data::illuminant_a();
        let g = t.grid();
        let a = illuminant_a_formula(&g);
        for (f, v) in a.iter().zip(&t.values[0]) {
            assert!((f - v).abs() <= 5e-6 * v, "{f} vs {v}");
        }
    }

    #[test]
    fn resample_integrate_normalise() {
        let g = WavelengthGrid::range(400.0, 420.0, 10.0).unwrap();
        let s = resample(&[390.0, 430.0], &[0.0, 4.0], &g).unwrap();
        assert_eq!(s, vec![1.0, 2.0, 3.0]);
        assert_eq!(integrate(&g, &s), 10.0 + 20.0 + 30.0);
        let mut m = multiply(&s, &[2.0, 2.0, 2.0]);
        normalise_peak(&mut m);
        assert_eq!(m, vec![1.0 / 3.0, 2.0 / 3.0, 1.0]);
        let wide = WavelengthGrid::range(380.0, 420.0, 10.0).unwrap();
        assert!(resample(&[390.0, 430.0], &[0.0, 4.0], &wide).is_err());
        let p = planck_relative(6500.0, &g);
        assert!(p.iter().all(|v| v.is_finite() && *v > 0.0));
    }
}
