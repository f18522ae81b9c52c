//! Analytic observers whose colour dimensionality is known, to validate CMF-SIM.
//!
//! - [`ConeObserver`]: the percept is `mixing · e`, where `e` are the K cone excitations of the
//!   patch (any template and peaks) and `mixing` an `(N × K)` matrix (identity by default). Its
//!   colour dimension is the rank of `mixing · F` — K for distinct classes.
//! - [`ConeObserver::rank_deficient_lms`]: four percept channels L, M, S and (L + M)/2 —
//!   four "classes" whose sensitivities span three dimensions; dimension 3.
//! - [`NakaRushtonObserver`]: cone excitations through `e / (e + σ)` — nonlinear, dimension K.
//! - [`LocationDependentObserver`]: the cone percept rotated by an orthogonal matrix that depends
//!   on where the patch is, so the same light looks different at two places; its base error
//!   exceeds the percept energy and CMF-SIM must refuse to give a dimension.
//!
//! All are noise-free and ignore the background (black); all but Naka–Rushton are linear in the
//! stimulus.

use rand::SeedableRng;

use crate::cones::{sensitivities, ConeClass, ConeFundamentals, ConeTemplate};
use crate::error::Result;
use crate::grid::WavelengthGrid;
use crate::observer::{grid_position, Observer, Show, Stimulus};

/// Percept = `mixing · cone excitations` of the patch.
#[derive(Debug, Clone)]
pub struct ConeObserver {
    name: String,
    fundamentals: ConeFundamentals,
    /// Row-major `(percept_dim × n_classes)`.
    mixing: Vec<f64>,
    percept_dim: usize,
}

impl ConeObserver {
    /// Percept = the cone excitations of `classes` with `template` on `grid`.
    pub fn new(
        classes: &[ConeClass],
        template: &ConeTemplate,
        grid: &WavelengthGrid,
    ) -> Result<Self> {
        let f = sensitivities(classes, template, grid)?;
        let k = classes.len();
        let mut eye = vec![0.0; k * k];
        for i in 0..k {
            eye[i * k + i] = 1.0;
        }
        let names: Vec<String> = classes
            .iter()
            .map(|c| format!("{}{:.0}", c.name, c.peak_nm))
            .collect();
        Ok(Self::with_mixing(
            format!("cones {}", names.join(" ")),
            f,
            eye,
        ))
    }

    /// Percept = `mixing · excitations`, `mixing` row-major `(N × K)`.
    ///
    /// # Panics
    /// If `mixing.len()` is not a multiple of the number of classes.
    pub fn with_mixing(name: String, fundamentals: ConeFundamentals, mixing: Vec<f64>) -> Self {
        let k = fundamentals.n_classes();
        assert!(
            k > 0 && mixing.len().is_multiple_of(k),
            "ConeObserver::with_mixing: mixing has {} values, not a multiple of K = {k}",
            mixing.len()
        );
        let percept_dim = mixing.len() / k;
        ConeObserver {
            name,
            fundamentals,
            mixing,
            percept_dim,
        }
    }

    /// L, M, S and a fourth channel (L + M)/2: four classes spanning three dimensions.
    pub fn rank_deficient_lms(template: &ConeTemplate, grid: &WavelengthGrid) -> Result<Self> {
        let f = sensitivities(&ConeClass::lms(), template, grid)?;
        #[rustfmt::skip]
        let mixing = vec![
            1.0, 0.0, 0.0,
            0.0, 1.0, 0.0,
            0.0, 0.0, 1.0,
            0.5, 0.5, 0.0,
        ];
        Ok(Self::with_mixing(
            "rank-deficient LMS+(L+M)/2".into(),
            f,
            mixing,
        ))
    }

    /// The fundamentals.
    pub fn fundamentals(&self) -> &ConeFundamentals {
        &self.fundamentals
    }

    /// Cone excitations of a stimulus (length K), into `out`.
    pub fn excitations_into(&self, stimulus: &Stimulus, out: &mut [f64]) {
        let f = &self.fundamentals;
        let k = f.n_classes();
        match stimulus {
            Stimulus::Spectrum(s) => f.excitations_into(s, out),
            Stimulus::Lines(lines) => {
                out.fill(0.0);
                for &(w, i) in lines {
                    let (g, t) = grid_position(&f.grid, w);
                    for c in 0..k {
                        let mut v = (1.0 - t) * f.get(g, c);
                        if t > 0.0 {
                            v += t * f.get(g + 1, c);
                        }
                        out[c] += i * v;
                    }
                }
            }
        }
    }

    fn percept_into(&self, stimulus: &Stimulus, exc: &mut [f64], out: &mut [f64]) {
        self.excitations_into(stimulus, exc);
        let k = exc.len();
        for (n, o) in out.iter_mut().enumerate() {
            *o = (0..k).map(|c| self.mixing[n * k + c] * exc[c]).sum();
        }
    }
}

impl Observer for ConeObserver {
    fn name(&self) -> String {
        self.name.clone()
    }
    fn grid(&self) -> &WavelengthGrid {
        &self.fundamentals.grid
    }
    fn percept_dim(&self) -> usize {
        self.percept_dim
    }
    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        let n = self.percept_dim;
        assert_eq!(
            out.len(),
            shows.len() * n,
            "ConeObserver::percepts: out length"
        );
        let mut exc = vec![0.0; self.fundamentals.n_classes()];
        for (show, o) in shows.iter().zip(out.chunks_exact_mut(n)) {
            self.percept_into(&show.stimulus, &mut exc, o);
        }
    }
}

/// A cone observer whose percept is rotated by a location-dependent orthogonal matrix: the field
/// is cut into `cells × cells` squares, each with its own random rotation (seeded).
#[derive(Debug, Clone)]
pub struct LocationDependentObserver {
    inner: ConeObserver,
    cells: usize,
    /// One row-major `(N × N)` orthogonal matrix per cell.
    rotations: Vec<Vec<f64>>,
}

impl LocationDependentObserver {
    /// Wrap `inner`; `cells` per side (at least 2), rotations drawn from `seed`.
    pub fn new(inner: ConeObserver, cells: usize, seed: u64) -> Self {
        let n = inner.percept_dim();
        let cells = cells.max(2);
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        let rotations = (0..cells * cells)
            .map(|_| crate::linalg::random_orthonormal_columns(n, n, &mut rng))
            .collect();
        LocationDependentObserver {
            inner,
            cells,
            rotations,
        }
    }

    fn cell(&self, loc: [f64; 2]) -> usize {
        let idx = |v: f64| (((v + 1.0) / 2.0 * self.cells as f64) as usize).min(self.cells - 1);
        idx(loc[1].clamp(-1.0, 1.0)) * self.cells + idx(loc[0].clamp(-1.0, 1.0))
    }
}

impl Observer for LocationDependentObserver {
    fn name(&self) -> String {
        format!("location-dependent {}", self.inner.name())
    }
    fn grid(&self) -> &WavelengthGrid {
        self.inner.grid()
    }
    fn percept_dim(&self) -> usize {
        self.inner.percept_dim()
    }
    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        let n = self.percept_dim();
        self.inner.percepts(shows, out);
        let mut tmp = vec![0.0; n];
        for (show, o) in shows.iter().zip(out.chunks_exact_mut(n)) {
            let q = &self.rotations[self.cell(show.location)];
            for (i, t) in tmp.iter_mut().enumerate() {
                *t = (0..n).map(|j| q[i * n + j] * o[j]).sum();
            }
            o.copy_from_slice(&tmp);
        }
    }
}

/// A cone observer with a compressive Naka–Rushton nonlinearity per channel,
/// `percept = e / (e + σ)`: nonlinear but injective, so its colour dimension is still the number
/// of classes. Exercises the solver's iterative (damped Gauss–Newton) path.
#[derive(Debug, Clone)]
pub struct NakaRushtonObserver {
    inner: ConeObserver,
    half_saturation: f64,
}

impl NakaRushtonObserver {
    /// Wrap `inner` with half-saturation constant σ (> 0, in excitation units).
    pub fn new(inner: ConeObserver, half_saturation: f64) -> Self {
        NakaRushtonObserver {
            inner,
            half_saturation,
        }
    }
}

impl Observer for NakaRushtonObserver {
    fn name(&self) -> String {
        format!(
            "Naka–Rushton σ={} {}",
            self.half_saturation,
            self.inner.name()
        )
    }
    fn grid(&self) -> &WavelengthGrid {
        self.inner.grid()
    }
    fn percept_dim(&self) -> usize {
        self.inner.percept_dim()
    }
    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        self.inner.percepts(shows, out);
        for v in out.iter_mut() {
            *v /= v.abs() + self.half_saturation;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::observer::percept_of;

    #[test]
    fn line_percept_equals_spectrum_percept() {
        let g = WavelengthGrid::default();
        let o = ConeObserver::new(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let a = percept_of(&o, Stimulus::monochromatic(512.5, 2.0), [0.0, 0.0]);
        let b = percept_of(
            &o,
            Stimulus::Spectrum(Stimulus::monochromatic(512.5, 2.0).to_grid(&g)),
            [0.5, 0.5],
        );
        assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-14));
        assert!(a.iter().all(|&v| v > 0.0));
    }

    #[test]
    fn location_dependent_observer_preserves_norm_but_not_direction() {
        let g = WavelengthGrid::default();
        let o = ConeObserver::new(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let ld = LocationDependentObserver::new(o, 4, 7);
        let s = Stimulus::monochromatic(550.0, 1.0);
        let a = percept_of(&ld, s.clone(), [-0.9, -0.9]);
        let b = percept_of(&ld, s, [0.9, 0.9]);
        let na: f64 = a.iter().map(|v| v * v).sum();
        let nb: f64 = b.iter().map(|v| v * v).sum();
        assert!((na - nb).abs() < 1e-12 * na);
        let d: f64 = a.iter().zip(&b).map(|(x, y)| (x - y).powi(2)).sum();
        assert!(d > 1e-3 * na);
    }
}
