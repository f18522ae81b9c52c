//! Gradient checks: the backward pass of any function recorded on a `Tape<f64>` against central
//! differences.
//!
//! How a check works ([`check_gradients`]):
//! - Every input becomes a tape leaf (or, with [`check_inputs`], a constant when it is not
//!   checked, e.g. a mask). `f` records the function; its output `y` may have any shape.
//! - A non-scalar output is reduced with fixed random weights `r ∈ [-1, 1]` (drawn from
//!   `cfg.seed`): `L = Σ r ⊙ y`, and backward is seeded with `r` through
//!   [`Tape::backward_from`]. A plain `sum()` would hide transposition and permutation bugs.
//!   A one-element output uses `r = 1`.
//! - An input with at most `cfg.max_full_elems` elements is checked element by element:
//!   `∂L/∂x_j ≈ (L(x + h e_j) − L(x − h e_j)) / 2h` with `h = eps · max(1, |x_j|)`.
//! - A larger input gets `cfg.probes` random directional probes: a unit-norm Gaussian direction
//!   `u`, compared as `uᵀ∇L` against `(L(x + h u) − L(x − h u)) / 2h` with
//!   `h = eps · max(1, ‖x‖₂)`.
//!
//! Error measure (one number per checked entry, analytic `a`, numeric `n`):
//! `err = |a − n| / max(1, |a|, |n|)` — absolute for small gradients, relative for large ones.
//! An entry fails when `|a − n| > atol + rtol · max(1, |a|, |n|)`, i.e. `err > rtol + atol / max(1, |a|, |n|)`.
//!
//! Surrogate gradients ([`Pointwise`] with `exact() == false`) have a `df` that is deliberately
//! not the derivative of `f`; [`check_surrogate`] compares their backward with the declared `df`.
//! Kinks (relu at 0, abs at 0) must be avoided by the caller's inputs.

use crate::op::Pointwise;
use crate::tape::NoHooks;
use crate::{Shape, Tape, Tensor, Var};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use std::fmt;
use std::rc::Rc;

mod probe;

use probe::{entry, finite, judge, probe_directions, probe_elements};

/// Settings of a gradient check. See the module docs for the error measure.
#[derive(Clone, Debug)]
pub struct CheckConfig {
    /// Finite-difference step, relative: `h = eps · max(1, |x|)`.
    pub eps: f64,
    /// Relative tolerance on `|a − n|`, scaled by `max(1, |a|, |n|)`.
    pub rtol: f64,
    /// Absolute tolerance added to `rtol · max(1, |a|, |n|)`.
    pub atol: f64,
    /// Inputs with at most this many elements are checked element by element.
    pub max_full_elems: usize,
    /// Number of random directional probes for each larger input.
    pub probes: usize,
    /// Seed of the reduction weights `r` and the probe directions.
    pub seed: u64,
}

impl Default for CheckConfig {
    /// `eps = 1e-6` balances the O(h²) truncation error of central differences against f64
    /// round-off (≈ 1e-16 · |L| / h); `rtol = 1e-6`, `atol = 1e-9` sit well above both for
    /// smooth functions of inputs in [-2, 2], and far below the O(1) error of a wrong backward.
    fn default() -> Self {
        CheckConfig {
            eps: 1e-6,
            rtol: 1e-6,
            atol: 1e-9,
            max_full_elems: 64,
            probes: 6,
            seed: 0x5eed,
        }
    }
}

/// How one entry was checked.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Probe {
    /// Element `flat` (row-major) of the input, by central differences.
    Element(usize),
    /// Random directional probe number `k`.
    Direction(usize),
}

/// One compared entry.
#[derive(Clone, Debug)]
pub struct Entry {
    /// Which input (position in `inputs`).
    pub input: usize,
    /// Shape of that input (for printing multi-indices).
    pub shape: Shape,
    /// Element or direction.
    pub probe: Probe,
    /// Backward's value.
    pub analytic: f64,
    /// Central-difference (or declared-`df`) value.
    pub numeric: f64,
    /// `|a − n| / max(1, |a|, |n|)`.
    pub rel_err: f64,
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let place = match self.probe {
            Probe::Element(j) => format!("flat {j} = {}", multi_index(self.shape, j)),
            Probe::Direction(k) => format!("probe {k}"),
        };
        write!(
            f,
            "input {} {:?} [{place}]: analytic {:+.9e}  numeric {:+.9e}  rel.err {:.2e}",
            self.input, self.shape, self.analytic, self.numeric, self.rel_err
        )
    }
}

fn multi_index(shape: Shape, mut flat: usize) -> String {
    let dims = shape.dims();
    let mut idx = vec![0; dims.len()];
    for a in (0..dims.len()).rev() {
        idx[a] = flat % dims[a];
        flat /= dims[a];
    }
    let s: Vec<String> = idx.iter().map(|i| i.to_string()).collect();
    format!("({})", s.join(", "))
}

/// A passed check.
#[derive(Clone, Debug)]
pub struct CheckReport {
    /// Number of compared entries (elements plus probes).
    pub checked: usize,
    /// Largest `err` over all entries.
    pub max_rel_err: f64,
    /// The entry with the largest error, if any entry was checked.
    pub worst: Option<Entry>,
}

/// A failed check.
#[derive(Clone, Debug)]
pub enum CheckError {
    /// Some entries exceed the tolerance; `worst` holds up to 10 of them, worst first.
    Mismatch {
        failed: usize,
        checked: usize,
        rtol: f64,
        atol: f64,
        worst: Vec<Entry>,
    },
    /// The function produced a non-finite value (forward output or a gradient).
    NonFinite { what: String },
    /// `check_inputs` was given a mask of the wrong length.
    BadMask { inputs: usize, mask: usize },
}

impl fmt::Display for CheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CheckError::Mismatch {
                failed,
                checked,
                rtol,
                atol,
                worst,
            } => {
                writeln!(
                    f,
                    "gradient check failed: {failed} of {checked} entries exceed |a−n| ≤ {atol:e} + {rtol:e}·max(1,|a|,|n|); worst first:"
                )?;
                for e in worst {
                    writeln!(f, "  {e}")?;
                }
                Ok(())
            }
            CheckError::NonFinite { what } => write!(f, "gradient check: non-finite {what}"),
            CheckError::BadMask { inputs, mask } => {
                write!(f, "check_inputs: {inputs} inputs but a mask of {mask}")
            }
        }
    }
}

impl std::error::Error for CheckError {}

/// Checks the gradient of `f` with respect to every input. See the module docs.
pub fn check_gradients(
    f: impl Fn(&mut Tape<f64>, &[Var]) -> Var,
    inputs: &[Tensor<f64>],
    cfg: &CheckConfig,
) -> Result<CheckReport, CheckError> {
    check_inputs(f, inputs, &vec![true; inputs.len()], cfg)
}

/// Like [`check_gradients`], but only inputs with `mask[i] == true` are leaves and checked; the
/// others are recorded as constants (integer-like data such as masks or indices).
pub fn check_inputs(
    f: impl Fn(&mut Tape<f64>, &[Var]) -> Var,
    inputs: &[Tensor<f64>],
    mask: &[bool],
    cfg: &CheckConfig,
) -> Result<CheckReport, CheckError> {
    if mask.len() != inputs.len() {
        return Err(CheckError::BadMask {
            inputs: inputs.len(),
            mask: mask.len(),
        });
    }
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let mut tape = Tape::<f64>::new();
    let (r, grads) = analytic_gradients(&mut tape, &f, inputs, mask, &mut rng)?;
    let mut loss = |xs: &[Tensor<f64>]| -> f64 {
        let (_, y) = record(&mut tape, &f, xs, mask);
        tape.value(y)
            .data()
            .iter()
            .zip(r.data())
            .map(|(a, b)| a * b)
            .sum()
    };

    let mut entries = Vec::new();
    let mut xs: Vec<Tensor<f64>> = inputs.to_vec();
    for i in (0..inputs.len()).filter(|&i| mask[i]) {
        if inputs[i].numel() <= cfg.max_full_elems {
            probe_elements(i, inputs, &grads[i], &mut xs, cfg, &mut loss, &mut entries);
        } else {
            probe_directions(
                i,
                inputs,
                &grads[i],
                &mut xs,
                cfg,
                &mut rng,
                &mut loss,
                &mut entries,
            );
        }
    }
    judge(entries, cfg)
}

/// Records `f` on a cleared tape: inputs with `mask` set become leaves, the others constants.
fn record(
    tape: &mut Tape<f64>,
    f: &impl Fn(&mut Tape<f64>, &[Var]) -> Var,
    xs: &[Tensor<f64>],
    mask: &[bool],
) -> (Vec<Var>, Var) {
    tape.clear();
    let vars: Vec<Var> = xs
        .iter()
        .zip(mask)
        .map(|(x, &m)| {
            if m {
                tape.leaf(x.clone())
            } else {
                tape.constant(x.clone())
            }
        })
        .collect();
    let y = f(tape, &vars);
    (vars, y)
}

/// Analytic gradients of `L = Σ r ⊙ f(inputs)`: draws the reduction weights `r` (all ones for
/// a scalar output, else uniform in [−1, 1) from `rng`), runs backward seeded with `r`, and
/// returns `r` with one gradient per input (zeros where the tape holds none). Fails when the
/// forward output or a checked input's gradient is not finite.
fn analytic_gradients(
    tape: &mut Tape<f64>,
    f: &impl Fn(&mut Tape<f64>, &[Var]) -> Var,
    inputs: &[Tensor<f64>],
    mask: &[bool],
    rng: &mut StdRng,
) -> Result<(Tensor<f64>, Vec<Tensor<f64>>), CheckError> {
    let (vars, y) = record(tape, f, inputs, mask);
    let y_shape = tape.shape(y);
    let r = if y_shape.numel() == 1 {
        Tensor::full(y_shape, 1.0)
    } else {
        Tensor::from_fn(y_shape, |_| rng.random_range(-1.0..1.0))
    };
    finite(tape.value(y).data(), "forward output")?;
    tape.backward_from(&[(y, r.clone())], &mut NoHooks);
    let grads: Vec<Tensor<f64>> = vars
        .iter()
        .zip(inputs)
        .map(|(&v, x)| {
            tape.grad(v)
                .cloned()
                .unwrap_or_else(|| Tensor::zeros(x.shape()))
        })
        .collect();
    for (i, g) in grads.iter().enumerate() {
        if mask[i] {
            finite(g.data(), &format!("gradient of input {i}"))?;
        }
    }
    Ok((r, grads))
}

/// Checks the backward of a (surrogate) [`Pointwise`] against its declared `df`: for each
/// element, `∂L/∂x_j` must equal `r_j · df(x_j, f(x_j))`, and the forward must equal `f(x_j)`.
/// Use this when `df` is deliberately not the derivative of `f`; finite differences would
/// (rightly) disagree with it.
pub fn check_surrogate<P: Pointwise>(
    p: P,
    x: &Tensor<f64>,
    cfg: &CheckConfig,
) -> Result<CheckReport, CheckError> {
    let p = Rc::new(p);
    let mut rng = StdRng::seed_from_u64(cfg.seed);
    let r = Tensor::from_fn(x.shape(), |_| rng.random_range(-1.0..1.0));
    let mut tape = Tape::<f64>::new();
    let v = tape.leaf(x.clone());
    let y = tape.map(Shared(p.clone()), v);
    tape.backward_from(&[(y, r.clone())], &mut NoHooks);
    let zeros = Tensor::zeros(x.shape());
    let g = tape.grad(v).unwrap_or(&zeros);
    let mut entries = Vec::with_capacity(2 * x.numel());
    for (j, &xj) in x.data().iter().enumerate() {
        let fx = p.f(xj);
        let yj = tape.value(y).data()[j];
        // Forward first (reported as input 0 with analytic = tape value, numeric = f(x)).
        entries.push(entry(0, x.shape(), Probe::Element(j), yj, fx));
        entries.push(entry(
            0,
            x.shape(),
            Probe::Element(j),
            g.data()[j],
            r.data()[j] * p.df(xj, fx),
        ));
    }
    judge(entries, cfg)
}

/// Lets a shared [`Pointwise`] be recorded while the checker keeps using it.
struct Shared<P>(Rc<P>);

impl<P: Pointwise> Pointwise for Shared<P> {
    fn name(&self) -> &'static str {
        self.0.name()
    }
    fn f(&self, x: f64) -> f64 {
        self.0.f(x)
    }
    fn df(&self, x: f64, y: f64) -> f64 {
        self.0.df(x, y)
    }
    fn exact(&self) -> bool {
        self.0.exact()
    }
}

#[cfg(test)]
pub mod strategies;

#[cfg(test)]
mod tests;
