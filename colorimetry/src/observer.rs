//! The black-box observer of CMF-SIM (paper S-04): "show this spectral stimulus as a patch at a
//! location on the background; return the percept vector".
//!
//! - A [`Stimulus`] is either a spectral power distribution on the observer's grid or a list of
//!   monochromatic components `(wavelength_nm, intensity)`. A component between two grid samples
//!   is split between them with linear weights ([`Stimulus::add_to_grid`]), which for a linear
//!   observer equals linearly interpolating its sensitivities (docs/references.md#cmf-sim-defaults, rendering).
//! - A location is a point of the observer's field in `[−1, 1]²` (x right, y down; the field's
//!   centre is the origin). The patch is centred there on the observer's background (black by
//!   default, docs/references.md#cmf-sim-defaults).
//! - The percept is a `Vec<f64>` of [`Observer::percept_dim`] values, e.g. the mean cortical
//!   N-vector over the patch.
//!
//! The root package implements [`Observer`] for retina + learned cortex; the analytic observers
//! live in [`crate::analytic`]. Calls are batched: [`Observer::percepts`] gets many [`Show`]s
//! and writes a row-major `(shows.len() × percept_dim)` block.

use rand::{Rng, RngCore};
use serde::{Deserialize, Serialize};

use crate::grid::WavelengthGrid;

/// A spectral stimulus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Stimulus {
    /// Spectral power on the observer's grid (one value per grid wavelength).
    Spectrum(Vec<f64>),
    /// Monochromatic components `(wavelength_nm, intensity)`; intensities ≥ 0.
    Lines(Vec<(f64, f64)>),
}

impl Stimulus {
    /// Black (no light).
    pub fn black() -> Self {
        Stimulus::Lines(Vec::new())
    }

    /// One monochromatic light.
    pub fn monochromatic(wavelength_nm: f64, intensity: f64) -> Self {
        Stimulus::Lines(vec![(wavelength_nm, intensity)])
    }

    /// Add the stimulus to a spectrum on `grid` (`out.len() == grid.len()`). A line outside the
    /// grid is clamped to the nearest end sample.
    ///
    /// # Panics
    /// If a `Spectrum` or `out` does not have the grid's length.
    pub fn add_to_grid(&self, grid: &WavelengthGrid, out: &mut [f64]) {
        assert_eq!(
            out.len(),
            grid.len(),
            "Stimulus::add_to_grid: out vs grid length"
        );
        match self {
            Stimulus::Spectrum(s) => {
                assert_eq!(
                    s.len(),
                    grid.len(),
                    "Stimulus::add_to_grid: spectrum vs grid length"
                );
                for (o, v) in out.iter_mut().zip(s) {
                    *o += v;
                }
            }
            Stimulus::Lines(lines) => {
                for &(w, i) in lines {
                    let (k, t) = grid_position(grid, w);
                    out[k] += (1.0 - t) * i;
                    if t > 0.0 {
                        out[k + 1] += t * i;
                    }
                }
            }
        }
    }

    /// The stimulus as a spectrum on `grid`.
    pub fn to_grid(&self, grid: &WavelengthGrid) -> Vec<f64> {
        let mut out = vec![0.0; grid.len()];
        self.add_to_grid(grid, &mut out);
        out
    }
}

/// `(k, t)` with `wavelength ≈ (1 − t)·grid[k] + t·grid[k + 1]`, clamped to the grid.
pub fn grid_position(grid: &WavelengthGrid, wavelength_nm: f64) -> (usize, f64) {
    let w = grid.as_slice();
    let n = w.len();
    if n == 1 || wavelength_nm <= w[0] {
        return (0, 0.0);
    }
    if wavelength_nm >= w[n - 1] {
        return (n - 1, 0.0);
    }
    let i = w.partition_point(|&x| x <= wavelength_nm);
    let t = (wavelength_nm - w[i - 1]) / (w[i] - w[i - 1]);
    (i - 1, t)
}

/// One presentation: a stimulus patch at a location, with a seed for the observer's noise (two
/// shows with the same seed see the same noise sample; CMF-SIM uses that for finite
/// differences).
#[derive(Debug, Clone, PartialEq)]
pub struct Show {
    /// The patch's light.
    pub stimulus: Stimulus,
    /// Patch centre in the field, `[−1, 1]²`.
    pub location: [f64; 2],
    /// Seed of the observer's noise for this show (ignored by noise-free observers).
    pub noise_seed: u64,
}

/// Default patch placement (docs/references.md#cmf-sim-defaults), in field units (`[−1, 1]²`, so 1 unit = 256 px of
/// the 512-px field): patch centres stay ≥ 24 px from the border.
pub const DEFAULT_BORDER_MARGIN: f64 = 24.0 / 256.0;
/// Minimum distance between the two patches of a pair (64 px of 512), field units
/// (docs/references.md#cmf-sim-defaults, chosen here).
pub const DEFAULT_MIN_PAIR_DISTANCE: f64 = 64.0 / 256.0;

/// A black-box colour observer (paper S-04).
pub trait Observer: Sync {
    /// A short description for logs and JSON.
    fn name(&self) -> String;

    /// The wavelength grid of `Stimulus::Spectrum`; monochromatic components must lie inside it.
    fn grid(&self) -> &WavelengthGrid;

    /// Length N of a percept vector.
    fn percept_dim(&self) -> usize;

    /// Show each stimulus patch at its location and write the percepts into `out`, row-major
    /// `(shows.len() × percept_dim)`. `out` arrives zeroed.
    fn percepts(&self, shows: &[Show], out: &mut [f64]);

    /// Intensity of a monochromatic test light that puts it in the observer's working range
    /// (docs/references.md#cmf-sim-defaults: largest single-cone response ≈ 0.5–0.8). CMF-SIM uses it for the test
    /// lights and as the unit of α. Default 1.
    fn stimulus_intensity(&self) -> f64 {
        1.0
    }

    /// The observer's linear front end, if it has one: rows `M_j` (each on [`Observer::grid`])
    /// such that the percept of any stimulus at a location depends on its spectrum `s` only
    /// through `v = M·s` (e.g. the cone-class excitations of a noise-free eye). CMF-SIM then
    /// measures Jacobians in `v` once per location pair and reuses them for every primary set
    /// ([`crate::matching::FrontEndJacobians`]); it shows spectra `M⁺·e_j`, which may be
    /// negative. Default: none.
    fn linear_front_end(&self) -> Option<Vec<Vec<f64>>> {
        None
    }

    /// Draw two distinct random patch locations (the two sides of a matching trial). Default:
    /// uniform in `[−1 + m, 1 − m]²` with `m =` [`DEFAULT_BORDER_MARGIN`], at least
    /// [`DEFAULT_MIN_PAIR_DISTANCE`] apart.
    fn location_pair(&self, rng: &mut dyn RngCore) -> [[f64; 2]; 2] {
        let lim = 1.0 - DEFAULT_BORDER_MARGIN;
        let mut draw = || [rng.random_range(-lim..lim), rng.random_range(-lim..lim)];
        let a = draw();
        loop {
            let b = draw();
            if ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() >= DEFAULT_MIN_PAIR_DISTANCE {
                return [a, b];
            }
        }
    }
}

/// Percept of one show (convenience; allocates).
pub fn percept_of(observer: &dyn Observer, stimulus: Stimulus, location: [f64; 2]) -> Vec<f64> {
    let mut out = vec![0.0; observer.percept_dim()];
    observer.percepts(
        &[Show {
            stimulus,
            location,
            noise_seed: 0,
        }],
        &mut out,
    );
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_split_between_neighbouring_samples() {
        let g = WavelengthGrid::range(400.0, 440.0, 10.0).unwrap();
        let s = Stimulus::Lines(vec![(412.5, 2.0), (440.0, 1.0), (300.0, 1.0)]).to_grid(&g);
        assert_eq!(s, vec![1.0, 1.5, 0.5, 0.0, 1.0]);
        let total: f64 = s.iter().sum();
        assert!((total - 4.0).abs() < 1e-15);
        assert_eq!(grid_position(&g, 420.0), (2, 0.0));
    }
}
