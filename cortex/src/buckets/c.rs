//! C, the cone spectral types (authors' code, docs/references.md#c-bucket; paper S-03 "Learning Color Types"): an N-vector
//! per cell.
//!
//! - Parameter `c.raw`, shape `(1, N, n, n)`, channel 0 = 1 and the rest 0 at start: every cell
//!   starts identical, a "monochromat".
//! - Effective `C = raw / (‖raw‖₂ + ε)` over the channel axis, recomputed at every use
//!   (ε = `c.norm_eps`, 1e-5): the paper's constraint C ⊙ C = 1.
//! - Inject (decode): `pa (B,1,n,n) → pa·C (B,N,n,n)`. Sample (encode): `Σₙ Vₙ·Cₙ (B,1,n,n)`.

use crate::config::CortexConfig;
use autodiff::{Float, ParamId, ParamStore, Tape, Tensor, Var};

/// The C bucket.
#[derive(Clone, Debug)]
pub struct CBucket {
    /// `c.raw`.
    pub raw: ParamId,
    /// ε of the normalisation.
    pub norm_eps: f64,
}

impl CBucket {
    /// Adds `c.raw` (e₁ everywhere) to `params`.
    pub fn new<T: Float>(params: &mut ParamStore<T>, cfg: &CortexConfig) -> Self {
        let (n, ch) = (cfg.ons_size_px, cfg.percept_channels);
        let init = Tensor::from_fn(
            [1, ch, n, n],
            |i| if i < n * n { T::one() } else { T::zero() },
        );
        CBucket {
            raw: params.add("c.raw", init),
            norm_eps: cfg.c.norm_eps,
        }
    }

    /// The effective, unit-norm C on the tape, `(1, N, n, n)` (record once per step).
    pub fn record<T: Float>(&self, tape: &mut Tape<T>, params: &ParamStore<T>) -> Var {
        let raw = params.var(tape, self.raw);
        tape.normalize_channels(raw, self.norm_eps)
    }

    /// Φ_C's injection `pa·C`.
    pub fn inject<T: Float>(&self, tape: &mut Tape<T>, c: Var, activations: Var) -> Var {
        tape.channel_outer(activations, c)
    }

    /// Ψ_C's sampling `⟨V, C⟩`.
    pub fn sample<T: Float>(&self, tape: &mut Tape<T>, c: Var, percept: Var) -> Var {
        tape.channel_dot(percept, c)
    }

    /// The effective C as plain data, `(n, n, N)` (cells row-major, channels last).
    pub fn effective<T: Float>(&self, params: &ParamStore<T>) -> Tensor<f64> {
        let raw = params.get(self.raw);
        let (_, ch, h, w) = raw.shape().bchw("CBucket::effective");
        let hw = h * w;
        let mut out = Tensor::<f64>::zeros([h, w, ch]);
        for p in 0..hw {
            let norm = (0..ch)
                .map(|c| raw.data()[c * hw + p].as_f64().powi(2))
                .sum::<f64>()
                .sqrt();
            for c in 0..ch {
                out.data_mut()[p * ch + c] =
                    raw.data()[c * hw + p].as_f64() / (norm + self.norm_eps);
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn starts_as_e1_and_inject_then_sample_is_identity() {
        let cfg = CortexConfig::tiny();
        let mut params = ParamStore::<f64>::new();
        let c = CBucket::new(&mut params, &cfg);
        let eff = c.effective(&params);
        let n = cfg.ons_size_px;
        for p in 0..n * n {
            assert!((eff.data()[p * 8] - 1.0).abs() < 1e-4);
            assert!(eff.data()[p * 8 + 1..p * 8 + 8].iter().all(|&v| v == 0.0));
        }
        // a random unit-norm C: sample(inject(pa)) = pa·‖C‖² ≈ pa
        let mut rng = crate::rng::CortexRng::seed_from(4);
        *params.get_mut(c.raw) = Tensor::from_fn([1, 8, n, n], |_| rng.normal());
        let mut tape = Tape::<f64>::new();
        let pa = Tensor::from_fn([2, 1, n, n], |i| (i as f64 * 0.37).sin());
        let pav = tape.constant(pa.clone());
        let cv = c.record(&mut tape, &params);
        let v = c.inject(&mut tape, cv, pav);
        assert_eq!(tape.shape(v).dims(), &[2, 8, n, n]);
        let back = c.sample(&mut tape, cv, v);
        assert!(tape.value(back).max_abs_diff(&pa) < 1e-4);
    }
}
