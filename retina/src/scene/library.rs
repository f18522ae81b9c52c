//! Measured surface reflectances and daylight illuminants on a wavelength grid.
//!
//! The reflectance library pools three measured sets embedded in `colorimetry` (provenance in
//! shared/data/README.md): the 1269 matte Munsell chips (Parkkinen et al. 1989), the 2696
//! distinct IES TM-30-15 real-object reflectances (David et al. 2015) and the 99 CIE 224:2017
//! colour-evaluation samples — 4064 spectra of real surfaces, natural and man-made.
//!
//! Illuminants are CIE D-series daylights from the S0/S1/S2 basis at a correlated colour
//! temperature (CIE 015:2018; `colorimetry::cie::daylight_spectrum`), scaled to luminance 1:
//! `Σ ȳ(λ)·E(λ)·Δλ = 1`, so a white surface under it has Y = 1.

use colorimetry::cie::{daylight_spectrum, CieObserver};
use colorimetry::{data, WavelengthGrid};

use crate::error::Result;

/// Measured reflectance spectra on a grid.
#[derive(Debug, Clone, PartialEq)]
pub struct ReflectanceLibrary {
    /// The grid.
    pub grid: WavelengthGrid,
    /// One spectrum per surface, each `grid.len()` long, factors in [0, 1].
    pub spectra: Vec<Vec<f64>>,
}

impl ReflectanceLibrary {
    /// Munsell 1269 + TM-30 (2696 distinct) + CES 99 on `grid` (module docs). Error if the grid
    /// leaves 380–780 nm, the range all three sets cover.
    pub fn measured(grid: &WavelengthGrid) -> Result<Self> {
        let mut spectra = Vec::with_capacity(4064);
        let munsell = data::munsell().resample(grid)?;
        spectra.extend(munsell.values);
        let tm30 = data::iestm30().resample(grid)?;
        for &i in data::iestm30_unique_indices() {
            spectra.push(tm30.values[i].clone());
        }
        let ces = data::ces99().resample(grid)?;
        spectra.extend(ces.values);
        for s in &mut spectra {
            s.iter_mut().for_each(|v| *v = v.clamp(0.0, 1.0));
        }
        Ok(ReflectanceLibrary {
            grid: grid.clone(),
            spectra,
        })
    }

    /// Number of surfaces.
    pub fn len(&self) -> usize {
        self.spectra.len()
    }

    /// True when empty.
    pub fn is_empty(&self) -> bool {
        self.spectra.is_empty()
    }
}

/// CIE daylight of `cct_k` (4000–25000 K) on `grid`, scaled to luminance 1 (module docs).
pub fn daylight_unit_luminance(cct_k: f64, grid: &WavelengthGrid) -> Result<Vec<f64>> {
    let e = daylight_spectrum(cct_k, grid)?;
    let obs = CieObserver::cie1931(grid)?;
    let y: f64 = e
        .iter()
        .zip(obs.cmf(1))
        .zip(grid.weights_nm())
        .map(|((a, b), w)| a * b * w)
        .sum();
    Ok(e.into_iter().map(|v| v / y).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn library_holds_4064_reflectances_in_range() {
        let g = WavelengthGrid::default();
        let lib = ReflectanceLibrary::measured(&g).unwrap();
        assert_eq!(lib.len(), 1269 + 2696 + 99);
        assert!(lib.spectra.iter().all(|s| s.len() == 31));
        assert!(lib
            .spectra
            .iter()
            .flatten()
            .all(|&v| (0.0..=1.0).contains(&v)));
        // Too wide a grid is an error, not an extrapolation.
        let wide = WavelengthGrid::range(360.0, 830.0, 10.0).unwrap();
        assert!(ReflectanceLibrary::measured(&wide).is_err());
    }

    #[test]
    fn daylight_has_unit_luminance_and_bluer_at_higher_cct() {
        let g = WavelengthGrid::default();
        let warm = daylight_unit_luminance(4000.0, &g).unwrap();
        let cool = daylight_unit_luminance(15000.0, &g).unwrap();
        // Blue (450 nm, index 5) to red (650 nm, index 25) ratio grows with CCT.
        assert!(cool[5] / cool[25] > 1.5 * warm[5] / warm[25]);
        let obs = CieObserver::cie1931(&g).unwrap();
        let y: f64 = (0..31).map(|i| warm[i] * obs.cmf(1)[i] * 10.0).sum();
        assert!((y - 1.0).abs() < 1e-12);
    }
}
