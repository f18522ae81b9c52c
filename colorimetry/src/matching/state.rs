//! Per-wavelength Levenberg–Marquardt state of [`super::solve_wavelengths`]; its steps come from
//! the kink-aware [`kink_step`].
//!
//! Layout: percepts of the two sides per pair are row-major `(pairs × N)`; the residual is
//! `r = Φ(B) − Φ(A)` with the same layout, flattened to `rows = pairs·N`; the Jacobian columns
//! `J⁻` (side A) and `J⁺` (side B) are row-major `(rows × K)`.

use super::kink::kink_step;
use super::{FrontEndJacobians, Resume, SolverSettings, WavelengthMatch};

/// LM state of one test wavelength.
pub(super) struct State {
    pub w: usize,
    k: usize,
    n: usize,
    pub alpha: Vec<f64>,
    pub trial: Vec<f64>,
    /// Φ(A), Φ(B) at `alpha`, `(pairs × N)`.
    pub pa: Vec<f64>,
    pub pb: Vec<f64>,
    /// Φ(A), Φ(B) at `trial`.
    ta: Vec<f64>,
    tb: Vec<f64>,
    err: f64,
    err0: f64,
    /// dr/dα_i on side A (valid where α_i ≤ 0) and side B (α_i ≥ 0), `(rows × K)`.
    ja: Vec<f64>,
    jb: Vec<f64>,
    /// The Jacobian columns may be used for the next step at `alpha`.
    pub j_valid: bool,
    /// They were differenced at `alpha` itself (not the front-end model).
    j_fresh: bool,
    mu: f64,
    /// Nielsen's growth factor of μ after a failed step.
    nu: f64,
    /// Predicted reduction of E by the current trial.
    predicted: f64,
    iterations: usize,
    pub active: bool,
    stopped_below: bool,
    /// Continued from an earlier solve.
    pub resumed: bool,
    /// Stopped for good (converged, exact, out of iterations or damping).
    converged: bool,
    /// Residual of the first step's model, when it is not `Φ(B) − Φ(A)` at α
    /// ([`FrontEndJacobians`]); dropped after the first accepted step.
    model_offset: Option<Vec<f64>>,
}

/// `mean_pairs ‖b − a‖²`.
fn mean_sq_diff(a: &[f64], b: &[f64], n: usize) -> f64 {
    let pairs = (a.len() / n.max(1)).max(1);
    a.iter().zip(b).map(|(x, y)| (y - x).powi(2)).sum::<f64>() / pairs as f64
}

impl State {
    pub fn new(w: usize, k: usize, pairs: usize, n: usize) -> Self {
        let rows = pairs * n;
        State {
            w,
            k,
            n,
            alpha: vec![0.0; k],
            trial: vec![0.0; k],
            pa: vec![0.0; rows],
            pb: vec![0.0; rows],
            ta: vec![0.0; rows],
            tb: vec![0.0; rows],
            err: 0.0,
            err0: 0.0,
            ja: vec![0.0; rows * k],
            jb: vec![0.0; rows * k],
            j_valid: false,
            j_fresh: false,
            mu: 0.0,
            nu: 2.0,
            predicted: 0.0,
            iterations: 0,
            active: false,
            stopped_below: false,
            resumed: false,
            converged: false,
            model_offset: None,
        }
    }

    /// Continue from an earlier solve `m` of the same problem: from the state after its last
    /// accepted step if it stopped below a threshold (the next action is the Jacobian at its α),
    /// else (it had converged) as final.
    pub fn resume(&mut self, m: &WavelengthMatch) {
        assert_eq!(m.alpha.len(), self.k, "State::resume: α of another problem");
        self.alpha.clone_from(&m.alpha);
        self.err = m.error;
        self.err0 = m.error_at_zero;
        self.iterations = m.iterations;
        self.stopped_below = m.stopped_below;
        self.resumed = true;
        self.j_valid = false;
        self.j_fresh = false;
        match &m.resume {
            Some(r) => {
                assert_eq!(
                    r.side_a.len(),
                    self.pa.len(),
                    "State::resume: percepts of another problem"
                );
                self.pa.copy_from_slice(&r.side_a);
                self.pb.copy_from_slice(&r.side_b);
                self.mu = r.mu;
                self.nu = r.nu;
                self.converged = false;
                self.active = true;
            }
            None => {
                self.converged = true;
                self.active = false;
            }
        }
    }

    /// E(0) from `pa`, `pb`; decide whether to iterate at all.
    pub fn start(&mut self, stop_below: Option<f64>, max_iterations: usize) {
        self.err0 = mean_sq_diff(&self.pa, &self.pb, self.n);
        self.err = self.err0;
        self.converged = !(self.k > 0 && self.err0 > 0.0) || max_iterations == 0;
        self.stopped_below = stop_below.is_some_and(|t| self.err0 < t);
        self.active = !self.converged && !self.stopped_below;
    }

    /// The first step's model from front-end Jacobians; false if they do not cover this
    /// wavelength.
    pub fn model_from(&mut self, f: &FrontEndJacobians, classes: &[Vec<f64>]) -> bool {
        let mut offset = Vec::new();
        let ok = f.model(self.w, classes, &mut self.ja, &mut self.jb, &mut offset);
        if ok {
            self.model_offset = Some(offset);
        }
        ok
    }

    /// Column `i` of pair `p` from the finite-difference show `percept` (side B if `on_b`).
    pub fn set_column(&mut self, p: usize, i: usize, on_b: bool, percept: &[f64], h: f64) {
        let (n, k) = (self.n, self.k);
        let (base, j) = if on_b {
            (&self.pb, &mut self.jb)
        } else {
            (&self.pa, &mut self.ja)
        };
        // On B, more of p_i raises Φ(B); on A, more of p_i means a lower α_i, so
        // (Φ(A') − Φ(A))/h is again dr/dα_i.
        for d in 0..n {
            let row = p * n + d;
            j[row * k + i] = (percept[d] - base[row]) / h;
        }
    }

    /// The columns were just differenced at `alpha`.
    pub fn mark_measured(&mut self) {
        self.j_valid = true;
        self.j_fresh = true;
    }

    /// Compute the trial α; returns whether side A and side B change.
    pub fn propose(&mut self) -> (bool, bool) {
        let r: Vec<f64> = match &self.model_offset {
            Some(offset) => offset.clone(),
            None => self.pb.iter().zip(&self.pa).map(|(b, a)| b - a).collect(),
        };
        let step = kink_step(&r, &self.ja, &self.jb, &self.alpha, self.mu);
        let pairs = (self.pa.len() / self.n.max(1)).max(1);
        self.predicted = self.err - step.model_residual / pairs as f64;
        for i in 0..self.k {
            self.trial[i] = self.alpha[i] + step.delta[i];
        }
        let neg = |v: f64| v.min(0.0);
        let pos = |v: f64| v.max(0.0);
        let change_a = (0..self.k).any(|i| neg(self.alpha[i]) != neg(self.trial[i]));
        let change_b = (0..self.k).any(|i| pos(self.alpha[i]) != pos(self.trial[i]));
        self.ta.copy_from_slice(&self.pa);
        self.tb.copy_from_slice(&self.pb);
        (change_a, change_b)
    }

    /// Store the trial percepts of pair `p` (`None`: that side did not change).
    pub fn take_trial(&mut self, p: usize, a: Option<&[f64]>, b: Option<&[f64]>) {
        let n = self.n;
        if let Some(a) = a {
            self.ta[p * n..(p + 1) * n].copy_from_slice(a);
        }
        if let Some(b) = b {
            self.tb[p * n..(p + 1) * n].copy_from_slice(b);
        }
    }

    /// Accept or reject the trial; update μ and decide whether to go on.
    pub fn judge(&mut self, s: &SolverSettings, stop_below: Option<f64>) {
        self.iterations += 1;
        let new = mean_sq_diff(&self.ta, &self.tb, self.n);
        let old = self.err;
        if new < old {
            std::mem::swap(&mut self.pa, &mut self.ta);
            std::mem::swap(&mut self.pb, &mut self.tb);
            self.alpha.clone_from(&self.trial);
            self.err = new;
            self.model_offset = None;
            // Nielsen (1999): shrink μ by up to 3× when the model predicted the gain well.
            let rho = if self.predicted > 0.0 {
                (old - new) / self.predicted
            } else {
                0.0
            };
            self.mu *= (1.0 - (2.0 * rho - 1.0).powi(3)).max(1.0 / 3.0);
            self.nu = 2.0;
            let exact = new <= s.exact_match_rel * self.err0;
            let small = old - new <= s.rel_tolerance * old;
            // Convergence is only declared on a step from a freshly differenced Jacobian.
            self.converged = exact || (small && self.j_fresh);
            self.stopped_below = stop_below.is_some_and(|t| new < t);
            self.j_valid = false;
            self.j_fresh = false;
            if self.converged || self.stopped_below {
                self.active = false;
            }
        } else if self.model_offset.take().is_some() {
            // A step from the front-end model failed: difference at α.
            self.j_valid = false;
        } else if new <= old * (1.0 + s.rel_tolerance) {
            // No meaningful change either way: α is at the (local) optimum.
            self.converged = true;
            self.active = false;
        } else {
            self.mu = if self.mu == 0.0 {
                1e-2
            } else {
                self.mu * self.nu
            };
            self.nu *= 2.0;
            if self.mu >= 1e8 {
                self.converged = true;
                self.active = false;
            }
        }
        if self.iterations >= s.max_iterations {
            self.converged = true;
            self.active = false;
        }
    }

    pub fn finish(self) -> WavelengthMatch {
        WavelengthMatch {
            wavelength: self.w,
            alpha: self.alpha,
            error: self.err,
            error_at_zero: self.err0,
            iterations: self.iterations,
            stopped_below: self.stopped_below,
            resume: (self.stopped_below && !self.converged).then_some(Resume {
                mu: self.mu,
                nu: self.nu,
                side_a: self.pa,
                side_b: self.pb,
            }),
        }
    }
}
