//! The kink-aware step [`kink_step`] of the per-wavelength Levenberg–Marquardt solver: the
//! damped Gauss–Newton step of a piecewise-linear model whose columns change at α_i = 0.
//!
//! Layout: the residual `r` has `rows = pairs·N` values; the Jacobian columns `J⁻` (side A,
//! valid where α_i ≤ 0) and `J⁺` (side B, α_i ≥ 0) are row-major `(rows × K)`.

use super::solve_small;

/// A step of the piecewise-linear model and what the model predicts for it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelStep {
    /// δ (K values).
    pub delta: Vec<f64>,
    /// `‖r + Jδ‖²`: the undamped model's residual, summed over rows.
    pub model_residual: f64,
}

/// The damped Gauss–Newton step δ of the piecewise-linear model
/// `r(α + δ) ≈ r + Σ_i c_i δ_i`, `c_i = J⁺_i` where α_i + δ_i > 0 and `J⁻_i` where < 0, restricted
/// to steps that cross no kink: an α_i ≠ 0 either stays on its side or stops at 0, an α_i = 0
/// stays or moves to either side.
///
/// Every such assignment (at most 3^K) is a small least-squares problem
/// `min ‖r' + J_free δ_free‖² + μ·Σ diag(JᵀJ)_i δ_i²` (stopped coordinates fixed at δ_i = −α_i
/// and folded into r'); assignments whose solution has a wrong sign are discarded (their
/// constrained optimum lies on a face, which is another assignment), and the lowest damped
/// model objective wins. `r` has `rows` values, `ja`, `jb` are row-major `(rows × K)`,
/// `K = alpha.len()`; `ja` is read only where α_i ≤ 0, `jb` where α_i ≥ 0.
///
/// # Panics
/// If the lengths disagree.
pub fn kink_step(r: &[f64], ja: &[f64], jb: &[f64], alpha: &[f64], mu: f64) -> ModelStep {
    let (rows, k) = (r.len(), alpha.len());
    assert!(
        ja.len() == rows * k && jb.len() == rows * k,
        "kink_step: J⁻ {} / J⁺ {} values for {rows} rows × {k}",
        ja.len(),
        jb.len()
    );
    let cols = Columns { ja, jb, rows, k };
    let r2 = sq(r);
    let mut best = ModelStep {
        delta: vec![0.0; k],
        model_residual: r2,
    };
    let mut best_objective = r2;
    // choice per coordinate: 0 = stay (α_i = 0) / stop at 0 (α_i ≠ 0); 1 = B side / keep side;
    // 2 = A side (only from α_i = 0)
    let radix: Vec<usize> = alpha
        .iter()
        .map(|&a| if a == 0.0 { 3 } else { 2 })
        .collect();
    let n_patterns: usize = radix.iter().product();
    let mut trial = Assignment {
        free: Vec::with_capacity(k),
        delta: vec![0.0; k],
        r_fixed: vec![0.0; rows],
        damping: 0.0,
    };
    for code in 0..n_patterns {
        trial.fix_stopped(code, &radix, &cols, r, alpha, mu);
        if !trial.solve_free(&cols, alpha, mu) {
            continue;
        }
        let model = sq(&trial.r_fixed);
        if model + trial.damping < best_objective {
            best_objective = model + trial.damping;
            best = ModelStep {
                delta: trial.delta.clone(),
                model_residual: model,
            };
        }
    }
    best
}

/// `Σ v²`.
fn sq(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>()
}

/// The two one-sided Jacobians, row-major `(rows × K)`.
struct Columns<'a> {
    ja: &'a [f64],
    jb: &'a [f64],
    rows: usize,
    k: usize,
}

impl Columns<'_> {
    /// Entry `(row, i)` of `J⁺` (`on_b`) or `J⁻`.
    fn at(&self, i: usize, on_b: bool, row: usize) -> f64 {
        if on_b {
            self.jb[row * self.k + i]
        } else {
            self.ja[row * self.k + i]
        }
    }

    /// `diag(JᵀJ)_i` of the chosen side: the squared norm of column `i`.
    fn diag(&self, i: usize, on_b: bool) -> f64 {
        (0..self.rows)
            .map(|row| self.at(i, on_b, row).powi(2))
            .sum::<f64>()
    }
}

/// One assignment of sides to the coordinates and its step, reused across assignments.
struct Assignment {
    /// Free coordinates and their side (`true` = B, α_i + δ_i > 0).
    free: Vec<(usize, bool)>,
    /// δ (K values).
    delta: Vec<f64>,
    /// `r + Σ c_i δ_i` over the coordinates fixed so far (`rows` values).
    r_fixed: Vec<f64>,
    /// `μ·Σ diag(JᵀJ)_i δ_i²` over the coordinates fixed so far.
    damping: f64,
}

impl Assignment {
    /// Decodes assignment `code` (mixed radix, one digit per coordinate): collects the free
    /// coordinates with their side and folds the coordinates stopped at the kink (δ_i = −α_i)
    /// into `r_fixed` and `damping`.
    fn fix_stopped(
        &mut self,
        code: usize,
        radix: &[usize],
        cols: &Columns,
        r: &[f64],
        alpha: &[f64],
        mu: f64,
    ) {
        self.free.clear();
        self.delta.fill(0.0);
        self.r_fixed.copy_from_slice(r);
        self.damping = 0.0;
        let side = |i: usize| alpha[i] > 0.0;
        let mut c = code;
        for i in 0..cols.k {
            let choice = c % radix[i];
            c /= radix[i];
            match (alpha[i] == 0.0, choice) {
                (true, 0) => {}
                (true, ch) => self.free.push((i, ch == 1)),
                (false, 1) => self.free.push((i, side(i))),
                (false, _) => {
                    // stop at the kink: δ_i = −α_i on α_i's side
                    self.delta[i] = -alpha[i];
                    for (row, rv) in self.r_fixed.iter_mut().enumerate() {
                        *rv += cols.at(i, side(i), row) * self.delta[i];
                    }
                    self.damping += mu * cols.diag(i, side(i)) * self.delta[i] * self.delta[i];
                }
            }
        }
    }

    /// Solves the damped least-squares problem of the free coordinates and folds the solution
    /// into `delta`, `r_fixed` and `damping`; returns `false` (leaving the fold undone) when a
    /// solution lands on the wrong side of its kink.
    fn solve_free(&mut self, cols: &Columns, alpha: &[f64], mu: f64) -> bool {
        let (rows, m) = (cols.rows, self.free.len());
        if m == 0 {
            return true;
        }
        let d: Vec<f64> = self.free.iter().map(|&(i, b)| cols.diag(i, b)).collect();
        let extra = if mu > 0.0 { m } else { 0 };
        let mut a = Vec::with_capacity((rows + extra) * m);
        for row in 0..rows {
            a.extend(self.free.iter().map(|&(i, b)| cols.at(i, b, row)));
        }
        let mut rhs: Vec<f64> = self.r_fixed.iter().map(|v| -v).collect();
        for j in 0..extra {
            a.extend((0..m).map(|c| {
                if c == j {
                    (mu * d[j].max(1e-300)).sqrt()
                } else {
                    0.0
                }
            }));
            rhs.push(0.0);
        }
        let x = solve_small(&a, rows + extra, m, &rhs);
        let consistent = self.free.iter().zip(&x).all(|(&(i, b), &v)| {
            let t = alpha[i] + v;
            if b {
                t > 0.0
            } else {
                t < 0.0
            }
        });
        if !consistent {
            return false;
        }
        for ((&(i, b), &v), dj) in self.free.iter().zip(&x).zip(&d) {
            self.delta[i] = v;
            for (row, rv) in self.r_fixed.iter_mut().enumerate() {
                *rv += cols.at(i, b, row) * v;
            }
            self.damping += mu * dj * v * v;
        }
        true
    }
}
