//! Wavelength grids.
//!
//! A [`WavelengthGrid`] is a strictly increasing list of finite wavelengths in nm. It need not be
//! uniform. Spectra "on a grid" are `&[f64]` with one value per grid wavelength, in grid order.
//!
//! The default grid is 400–700 nm every 10 nm (31 samples), the NTIRE band layout of the
//! authors' code (docs/references.md#spectral-grid). The authors' code works at 1 nm on 400–700
//! (301 samples): [`WavelengthGrid::official_1nm`].

use crate::error::{ColorimetryError, Result};

/// Default first wavelength of the project grid, nm: the NTIRE scenes' 31 bands, 400–700 nm
/// every 10 nm (Arad et al. 2022; docs/references.md#spectral-grid).
pub const DEFAULT_START_NM: f64 = 400.0;
/// Default last wavelength of the project grid, nm (NTIRE's 31 bands, as above).
pub const DEFAULT_END_NM: f64 = 700.0;
/// Default spacing of the project grid, nm (NTIRE's 31 bands, as above).
pub const DEFAULT_STEP_NM: f64 = 10.0;

/// A strictly increasing list of wavelengths in nm.
#[derive(Debug, Clone, PartialEq)]
pub struct WavelengthGrid {
    wavelengths_nm: Vec<f64>,
}

impl WavelengthGrid {
    /// A grid from arbitrary wavelengths (nm). They must be finite, positive and strictly
    /// increasing, and there must be at least one.
    pub fn new(wavelengths_nm: Vec<f64>) -> Result<Self> {
        if wavelengths_nm.is_empty() {
            return Err(ColorimetryError::InvalidGrid("no wavelengths".into()));
        }
        for (i, &w) in wavelengths_nm.iter().enumerate() {
            if !w.is_finite() || w <= 0.0 {
                return Err(ColorimetryError::InvalidGrid(format!(
                    "wavelength #{i} is {w}; wavelengths must be finite and positive (nm)"
                )));
            }
            if i > 0 && w <= wavelengths_nm[i - 1] {
                return Err(ColorimetryError::InvalidGrid(format!(
                    "wavelength #{i} ({w} nm) is not greater than #{} ({} nm)",
                    i - 1,
                    wavelengths_nm[i - 1]
                )));
            }
        }
        Ok(WavelengthGrid { wavelengths_nm })
    }

    /// `start_nm, start_nm + step_nm, …, end_nm` (both ends included). `end_nm − start_nm` must
    /// be a whole number of steps (to 1e-6 of a step). Points are computed as `start + i·step`,
    /// so no rounding error accumulates.
    pub fn range(start_nm: f64, end_nm: f64, step_nm: f64) -> Result<Self> {
        if !(step_nm > 0.0 && step_nm.is_finite()) {
            return Err(ColorimetryError::InvalidGrid(format!(
                "step_nm is {step_nm}; it must be positive"
            )));
        }
        if !(start_nm.is_finite() && end_nm.is_finite()) || end_nm < start_nm {
            return Err(ColorimetryError::InvalidGrid(format!(
                "range {start_nm}–{end_nm} nm is empty or not finite"
            )));
        }
        let steps = (end_nm - start_nm) / step_nm;
        let n = steps.round();
        if (steps - n).abs() > 1e-6 {
            return Err(ColorimetryError::InvalidGrid(format!(
                "{start_nm}–{end_nm} nm is not a whole number of {step_nm}-nm steps"
            )));
        }
        let n = n as usize + 1;
        Self::new((0..n).map(|i| start_nm + i as f64 * step_nm).collect())
    }

    /// `n` equally spaced wavelengths from `start_nm` to `end_nm` inclusive (`n ≥ 2`), e.g. the
    /// 100 CMF-SIM test wavelengths 400–700 nm (paper S-04).
    pub fn linspace(start_nm: f64, end_nm: f64, n: usize) -> Result<Self> {
        if n < 2 {
            return Err(ColorimetryError::InvalidGrid(format!(
                "linspace needs at least 2 points, got {n}"
            )));
        }
        let step = (end_nm - start_nm) / (n - 1) as f64;
        Self::new((0..n).map(|i| start_nm + i as f64 * step).collect())
    }

    /// The official code's grid: 400–700 nm every 1 nm, 301 samples (authors' code, docs/references.md#spectral-grid).
    pub fn official_1nm() -> Self {
        Self::range(400.0, 700.0, 1.0).expect("constant grid is valid")
    }

    /// The wavelengths, nm.
    pub fn wavelengths_nm(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Same as [`WavelengthGrid::wavelengths_nm`].
    pub fn as_slice(&self) -> &[f64] {
        &self.wavelengths_nm
    }

    /// Number of wavelengths.
    pub fn len(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// Always false (a grid has at least one wavelength); present for clippy's sake.
    pub fn is_empty(&self) -> bool {
        self.wavelengths_nm.is_empty()
    }

    /// First wavelength, nm.
    pub fn min_nm(&self) -> f64 {
        self.wavelengths_nm[0]
    }

    /// Last wavelength, nm.
    pub fn max_nm(&self) -> f64 {
        *self.wavelengths_nm.last().expect("grid is non-empty")
    }

    /// Index of the grid wavelength nearest to `wavelength_nm`.
    pub fn nearest_index(&self, wavelength_nm: f64) -> usize {
        let w = &self.wavelengths_nm;
        let i = w.partition_point(|&x| x < wavelength_nm);
        if i == 0 {
            0
        } else if i == w.len() || (wavelength_nm - w[i - 1]) <= (w[i] - wavelength_nm) {
            i - 1
        } else {
            i
        }
    }

    /// Quadrature weights Δλ (nm) for sums `Σ f(λ_i)·Δλ_i` over the grid. Interior points get
    /// half the distance between their neighbours; each end point gets the full spacing to its
    /// one neighbour. On a uniform grid every weight equals the step, which is the CIE 015
    /// summation `Σ … Δλ`. A one-point grid gets weight 1.
    pub fn weights_nm(&self) -> Vec<f64> {
        let w = &self.wavelengths_nm;
        let n = w.len();
        if n == 1 {
            return vec![1.0];
        }
        (0..n)
            .map(|i| {
                if i == 0 {
                    w[1] - w[0]
                } else if i == n - 1 {
                    w[n - 1] - w[n - 2]
                } else {
                    0.5 * (w[i + 1] - w[i - 1])
                }
            })
            .collect()
    }
}

impl Default for WavelengthGrid {
    /// 400–700 nm every 10 nm (the NTIRE bands).
    fn default() -> Self {
        Self::range(DEFAULT_START_NM, DEFAULT_END_NM, DEFAULT_STEP_NM).expect("constant grid")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_grid_is_400_to_700_every_10() {
        let g = WavelengthGrid::default();
        assert_eq!(g.len(), 31);
        assert_eq!(g.min_nm(), 400.0);
        assert_eq!(g.max_nm(), 700.0);
        assert_eq!(WavelengthGrid::official_1nm().len(), 301);
    }

    #[test]
    fn invalid_grids_are_errors() {
        assert!(WavelengthGrid::new(vec![]).is_err());
        assert!(WavelengthGrid::new(vec![400.0, 400.0]).is_err());
        assert!(WavelengthGrid::new(vec![400.0, f64::NAN]).is_err());
        assert!(WavelengthGrid::range(400.0, 705.0, 10.0).is_err());
        assert!(WavelengthGrid::range(400.0, 700.0, 0.0).is_err());
        assert!(WavelengthGrid::linspace(400.0, 700.0, 1).is_err());
    }

    #[test]
    fn weights_and_nearest() {
        let g = WavelengthGrid::new(vec![400.0, 410.0, 430.0]).unwrap();
        assert_eq!(g.weights_nm(), vec![10.0, 15.0, 20.0]);
        assert_eq!(g.nearest_index(404.0), 0);
        assert_eq!(g.nearest_index(421.0), 2);
        assert_eq!(g.nearest_index(1000.0), 2);
        let l = WavelengthGrid::linspace(400.0, 700.0, 100).unwrap();
        assert_eq!(l.len(), 100);
        assert!((l.max_nm() - 700.0).abs() < 1e-12);
    }
}
