//! Jacobians at α = 0 through the observer's linear front end, measured once per (test
//! wavelength, location pair) and reused for every primary set.
//!
//! If the percept at a location depends on the stimulus spectrum `s` only through `v = M·s`
//! ([`Observer::linear_front_end`], `M` is `m × grid`, e.g. the cone-class excitations), the
//! first step of every primary set can come from a model measured once per (test wavelength,
//! location pair), without shows of the primaries:
//!
//! - side A (the test light `v_t = M·line(λ)·I` at a, plus primaries):
//!   `Φ_a(v) ≈ Φ_a(v_t) + G_a (v − v_t)`, `G_a = ∂Φ_a/∂v` at `v_t`;
//! - side B, linearised where a match puts it — near the test light, not at black (a learned
//!   decoder is far from linear between black and a light):
//!   `Φ_b(v) ≈ Φ_b(v_t) + G_b (v − v_t)`, `G_b = ∂Φ_b/∂v` at `v_t`.
//!
//! So at α = 0 the model residual is `r̃ = Φ_b(v_t) − Φ_a(v_t) − G_b v_t` with columns
//! `J⁺_i = G_b c_i I`, `J⁻_i = G_a c_i I` (`c_i = M·line(p_i)`). Φ_a(v_t), Φ_b(v_t) are the base
//! step's shows; `G` is measured by forward differences along the `m` axes of `v` (spectra
//! `M⁺·e_j`, which may be negative: the front end is linear) with step
//! `ε_j = h · I · max_λ M_j(λ)` (the α-space step h on a primary at class j's peak), sharing the
//! noise seeds of those base shows. That is `2m` shows per (wavelength, pair) once, instead of
//! `2K` per (wavelength, pair) for every primary set. The step is then evaluated with real shows
//! and the solve continues with α-space differences; the model only chooses the first trial.

use super::{show_seed, MatchProblem};
use crate::linalg::{lstsq, DEFAULT_RCOND};
use crate::observer::{Observer, Show, Stimulus};

/// Percepts of the test light at both locations of every pair (the base step's shows),
/// row-major `(wavelengths × pairs × N)`.
#[derive(Debug, Clone, Copy)]
pub struct TestPercepts<'a> {
    /// Φ(test at a), seed `show_seed(seed, w, p, 1)`.
    pub at_a: &'a [f64],
    /// Φ(test at b), seed `show_seed(seed, w, p, 3)`.
    pub at_b: &'a [f64],
}

/// The model of one test wavelength.
#[derive(Debug, Clone)]
struct Linearisation {
    ga: Vec<f64>,
    gb: Vec<f64>,
    offset: Vec<f64>,
}

/// `G_a`, `G_b` and `r̃` per test wavelength (filled on demand).
#[derive(Debug, Clone)]
pub struct FrontEndJacobians {
    /// Rows of the front end.
    m: usize,
    /// `M`, row-major `(m × grid)`.
    front: Vec<f64>,
    grid_len: usize,
    /// `ε_j · M⁺ e_j` as grid spectra.
    steps: Vec<Vec<f64>>,
    /// ε_j.
    eps: Vec<f64>,
    /// Per wavelength: `G_a`, `G_b` (each row-major `(pairs × N × m)`) and `r̃` (`pairs × N`).
    at: Vec<Option<Linearisation>>,
}

impl FrontEndJacobians {
    /// For `observer` (None without a front end), `n_wavelengths` test wavelengths, test
    /// intensity `intensity` and α-space difference step `fd_step`.
    pub fn new(
        observer: &dyn Observer,
        n_wavelengths: usize,
        intensity: f64,
        fd_step: f64,
    ) -> Option<Self> {
        let rows = observer.linear_front_end()?;
        let g = observer.grid().len();
        let m = rows.len();
        if m == 0 || rows.iter().any(|r| r.len() != g) {
            return None;
        }
        let front: Vec<f64> = rows.concat();
        let mut steps = Vec::with_capacity(m);
        let mut eps = Vec::with_capacity(m);
        for (j, row) in rows.iter().enumerate() {
            let peak = row.iter().fold(0.0f64, |a, v| a.max(v.abs()));
            let e = fd_step * intensity * peak.max(f64::MIN_POSITIVE);
            let mut unit = vec![0.0; m];
            unit[j] = e;
            // minimum-norm spectrum q with M·q = ε_j e_j
            steps.push(lstsq(&front, m, g, &unit, 1, DEFAULT_RCOND).x);
            eps.push(e);
        }
        Some(FrontEndJacobians {
            m,
            front,
            grid_len: g,
            steps,
            eps,
            at: vec![None; n_wavelengths],
        })
    }

    /// Whether `G` is known for wavelength `w`.
    pub fn has(&self, w: usize) -> bool {
        self.at.get(w).is_some_and(Option::is_some)
    }

    /// Measure the model for the wavelengths of `which` that lack it, in one batched call;
    /// `known` are the base step's test-light percepts at a (seed 1 of `pb.seed`) and b
    /// (seed 3). Returns the shows evaluated.
    pub fn measure(
        &mut self,
        pb: &MatchProblem<'_>,
        which: &[usize],
        known: TestPercepts<'_>,
    ) -> usize {
        let n = pb.observer.percept_dim();
        let grid = pb.observer.grid();
        let todo: Vec<usize> = which.iter().copied().filter(|&w| !self.has(w)).collect();
        let mut shows = Vec::new();
        for &w in &todo {
            let test =
                Stimulus::monochromatic(pb.test_wavelengths_nm[w], pb.intensity).to_grid(grid);
            for (p, &[a, b]) in pb.pairs[w].iter().enumerate() {
                for step in &self.steps {
                    let side_a: Vec<f64> = test.iter().zip(step).map(|(t, d)| t + d).collect();
                    shows.push(Show {
                        stimulus: Stimulus::Spectrum(side_a),
                        location: a,
                        noise_seed: show_seed(pb.seed, w, p, 1),
                    });
                    let side_b: Vec<f64> = test.iter().zip(step).map(|(t, d)| t + d).collect();
                    shows.push(Show {
                        stimulus: Stimulus::Spectrum(side_b),
                        location: b,
                        noise_seed: show_seed(pb.seed, w, p, 3),
                    });
                }
            }
        }
        if shows.is_empty() {
            return 0;
        }
        let mut out = vec![0.0; shows.len() * n];
        pb.observer.percepts(&shows, &mut out);
        let offsets: Vec<usize> = pb
            .pairs
            .iter()
            .scan(0, |acc, v| {
                let o = *acc;
                *acc += v.len();
                Some(o)
            })
            .collect();
        let mut s = 0;
        for &w in &todo {
            let np = pb.pairs[w].len();
            let (mut ga, mut gb) = (vec![0.0; np * n * self.m], vec![0.0; np * n * self.m]);
            let mut offset = vec![0.0; np * n];
            let vt: Vec<f64> = self
                .class_vector(grid, pb.test_wavelengths_nm[w])
                .into_iter()
                .map(|v| v * pb.intensity)
                .collect();
            for p in 0..np {
                let base = (offsets[w] + p) * n;
                for j in 0..self.m {
                    for d in 0..n {
                        let row = (p * n + d) * self.m + j;
                        ga[row] = (out[s * n + d] - known.at_a[base + d]) / self.eps[j];
                        gb[row] = (out[(s + 1) * n + d] - known.at_b[base + d]) / self.eps[j];
                    }
                    s += 2;
                }
                for d in 0..n {
                    let row = p * n + d;
                    let gv: f64 = (0..self.m).map(|j| gb[row * self.m + j] * vt[j]).sum();
                    offset[row] = known.at_b[base + d] - known.at_a[base + d] - gv;
                }
            }
            self.at[w] = Some(Linearisation { ga, gb, offset });
        }
        shows.len()
    }

    /// `c = M·line(λ)` for a unit-intensity line.
    pub fn class_vector(&self, grid: &crate::grid::WavelengthGrid, wavelength_nm: f64) -> Vec<f64> {
        let line = Stimulus::monochromatic(wavelength_nm, 1.0).to_grid(grid);
        (0..self.m)
            .map(|j| {
                self.front[j * self.grid_len..(j + 1) * self.grid_len]
                    .iter()
                    .zip(&line)
                    .map(|(a, b)| a * b)
                    .sum()
            })
            .collect()
    }

    /// Fill the α = 0 model of wavelength `w` for primaries with class vectors `classes`
    /// (already times I): columns `ja`, `jb` (row-major `(pairs·N × K)`) and the residual
    /// `offset` (`pairs·N`). Returns false when the model of `w` is unknown.
    pub fn model(
        &self,
        w: usize,
        classes: &[Vec<f64>],
        ja: &mut [f64],
        jb: &mut [f64],
        offset: &mut Vec<f64>,
    ) -> bool {
        let Some(lin) = self.at.get(w).and_then(Option::as_ref) else {
            return false;
        };
        let (ga, gb) = (&lin.ga, &lin.gb);
        offset.clone_from(&lin.offset);
        let (m, k) = (self.m, classes.len());
        let rows = ga.len() / m;
        assert_eq!(
            ja.len(),
            rows * k,
            "FrontEndJacobians::columns: J⁻ {} vs {rows}×{k}",
            ja.len()
        );
        for row in 0..rows {
            for (i, c) in classes.iter().enumerate() {
                let dot = |g: &[f64]| (0..m).map(|j| g[row * m + j] * c[j]).sum::<f64>();
                ja[row * k + i] = dot(ga);
                jb[row * k + i] = dot(gb);
            }
        }
        true
    }
}
