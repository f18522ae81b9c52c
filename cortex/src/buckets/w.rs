//! W, the lateral-inhibition weights (authors' code, docs/references.md#w-bucket; paper S-03 "Learning Lateral Inhibition
//! Neighbor Weights"): a free complex frequency response on the `(2n−1)²` zero-padded grid.
//!
//! - Parameter `w.response`, shape `(2n−1, 2n−1, 2)` (re, im), natural FFT order, the kernel's
//!   origin at grid cell `(n−1, n−1)` (geometry of `autodiff::ops::fourier::convolve`).
//!   522 242 reals at n = 256, like the official 511² array.
//! - Initialisation: the FFT of a centred delta (`identity_response`): encode and decode are
//!   the identity at step 0 (decode exactly `x/(1 + ε)`).
//! - Encode Ψ_W: same-size linear convolution, `fft_convolve_same`.
//! - Decode Φ_W: the guarded inverse `X·conj(W)/(|W|² + ε)`, ε = `w.inverse_guard` (1e-6,
//!   docs/references.md#guarded-w-inverse; the official code divides unguarded).
//! - No constraint on symmetry, realness or support (as official).
//! - [`WMode::Identity`]: both are no-ops and there is no parameter (official sandbox).
//!
//! Images are `(B, 1, n, n)`.

use crate::config::{CortexConfig, WMode};
use autodiff::ops::fourier::convolve::{identity_response, kernel_response, response_kernel};
use autodiff::{Float, ParamId, ParamStore, Tape, Tensor, Var};

/// The W bucket: its parameter (if learned) and guard.
#[derive(Clone, Debug)]
pub struct WBucket {
    /// `w.response`, absent in identity mode.
    pub response: Option<ParamId>,
    /// ε of the guarded inverse.
    pub inverse_guard: f64,
}

impl WBucket {
    /// Adds `w.response` (identity at start) to `params` when W is learned.
    pub fn new<T: Float>(params: &mut ParamStore<T>, cfg: &CortexConfig) -> Self {
        let response = match cfg.w.mode {
            WMode::Learned => {
                Some(params.add("w.response", identity_response::<T>(cfg.ons_size_px)))
            }
            WMode::Identity => None,
        };
        WBucket {
            response,
            inverse_guard: cfg.w.inverse_guard,
        }
    }

    /// Records the response on the tape (once per step; decode and encode share it).
    pub fn record<T: Float>(&self, tape: &mut Tape<T>, params: &ParamStore<T>) -> Option<Var> {
        self.response.map(|id| params.var(tape, id))
    }

    /// Φ_W: ONS → cone activations, the guarded inverse filter.
    pub fn decode<T: Float>(&self, tape: &mut Tape<T>, response: Option<Var>, ons: Var) -> Var {
        match response {
            Some(r) => tape.fft_deconvolve_same(ons, r, self.inverse_guard),
            None => ons,
        }
    }

    /// Ψ_W: cone activations → ONS, the forward filter.
    pub fn encode<T: Float>(
        &self,
        tape: &mut Tape<T>,
        response: Option<Var>,
        activations: Var,
    ) -> Var {
        match response {
            Some(r) => tape.fft_convolve_same(activations, r),
            None => activations,
        }
    }

    /// The learned kernel around its origin, `k×k` (official logging: k = 7): the real part of
    /// the response's inverse FFT. `None` in identity mode.
    pub fn kernel<T: Float>(&self, params: &ParamStore<T>, k: usize) -> Option<Tensor<f64>> {
        self.response.map(|id| response_kernel(params.get(id), k))
    }

    /// Sets the response to the filter of a `k×k` kernel (origin at its centre). For
    /// diagnostics that start W somewhere chosen (e.g. at the eye's true kernel, to see whether
    /// the loss keeps it); `false` in identity mode.
    pub fn set_kernel<T: Float>(&self, params: &mut ParamStore<T>, kernel: &Tensor<f64>) -> bool {
        let Some(id) = self.response else {
            return false;
        };
        let n = params.get(id).dims()[0].div_ceil(2);
        let response: Tensor<T> = kernel_response(kernel, n, n);
        *params.get_mut(id) = response;
        true
    }

    /// Sets the filter's gain at zero frequency to `gain` (the response at the grid's origin
    /// becomes `gain + 0i`; every other frequency is kept). For diagnostics of what the loss
    /// identifies; `false` in identity mode.
    pub fn set_dc_gain<T: Float>(&self, params: &mut ParamStore<T>, gain: f64) -> bool {
        let Some(id) = self.response else {
            return false;
        };
        let data = params.get_mut(id).data_mut();
        data[0] = T::of(gain);
        data[1] = T::of(0.0);
        true
    }

    /// The learned filter's gain at zero frequency (the sum of its kernel): the real part of the
    /// response at the grid's origin. 1 for the initial identity; `None` in identity mode.
    pub fn dc_gain<T: Float>(&self, params: &ParamStore<T>) -> Option<f64> {
        self.response.map(|id| params.get(id).data()[0].as_f64())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::CortexRng;

    fn image(n: usize, border: usize, rng: &mut CortexRng) -> Tensor<f64> {
        Tensor::from_fn([2, 1, n, n], |i| {
            let (y, x) = ((i / n) % n, i % n);
            let inside = y >= border && x >= border && y < n - border && x < n - border;
            if inside {
                rng.normal()
            } else {
                0.0
            }
        })
    }

    #[test]
    fn identity_at_start_both_ways() {
        let cfg = CortexConfig::tiny();
        let mut params = ParamStore::<f64>::new();
        let w = WBucket::new(&mut params, &cfg);
        let mut tape = Tape::<f64>::new();
        let mut rng = CortexRng::seed_from(1);
        let x = image(cfg.ons_size_px, 0, &mut rng);
        let xv = tape.constant(x.clone());
        let r = w.record(&mut tape, &params);
        let enc = w.encode(&mut tape, r, xv);
        let dec = w.decode(&mut tape, r, xv);
        assert!(tape.value(enc).max_abs_diff(&x) < 1e-12);
        assert!(tape.value(dec).max_abs_diff(&x) < 1e-5);
        assert!((w.dc_gain(&params).unwrap() - 1.0).abs() < 1e-12);
        let k = w.kernel(&params, 7).unwrap();
        assert!(
            (k.data()[24] - 1.0).abs() < 1e-12
                && k.data().iter().map(|v| v.abs()).sum::<f64>() < 1.0 + 1e-9
        );
    }

    /// W inverse∘forward = identity to 1e-5 (f64 path), for a learned,
    /// non-trivial response (a random 7×7 kernel, |W| ≥ 0.5). The crop of the forward filter cuts
    /// what spills over the image edge, so the image is zero within the kernel radius of it.
    #[test]
    fn inverse_after_forward_is_identity_f64() {
        let n = 24;
        let mut rng = CortexRng::seed_from(2);
        let mut k = Tensor::<f64>::from_fn([7, 7], |_| 0.02 * rng.normal());
        k.data_mut()[24] = 1.0;
        let resp: Tensor<f64> = kernel_response(&k, n, n);
        let min_abs = resp
            .data()
            .chunks(2)
            .map(|c| (c[0] * c[0] + c[1] * c[1]).sqrt())
            .fold(f64::MAX, f64::min);
        assert!(min_abs > 0.5, "test kernel badly conditioned: {min_abs}");
        let mut params = ParamStore::<f64>::new();
        let id = params.add("w.response", resp);
        let w = WBucket {
            response: Some(id),
            inverse_guard: 1e-6,
        };
        let mut tape = Tape::<f64>::new();
        let x = image(n, 3, &mut rng);
        let xv = tape.constant(x.clone());
        let r = w.record(&mut tape, &params);
        let y = w.encode(&mut tape, r, xv);
        assert!(
            tape.value(y).max_abs_diff(&x) > 0.1,
            "the filter must do something"
        );
        let back = w.decode(&mut tape, r, y);
        let err = tape.value(back).max_abs_diff(&x);
        assert!(err < 1e-5, "inverse∘forward error {err}");
        // the learned kernel read back from the response
        let k7 = w.kernel(&params, 7).unwrap();
        assert!(k7.max_abs_diff(&k) < 1e-12);
        let dc = w.dc_gain(&params).unwrap();
        assert!(
            (dc - k.data().iter().sum::<f64>()).abs() < 1e-12,
            "DC gain {dc}"
        );
        // Setting the DC gain moves the kernel's sum there and no other frequency: the kernel
        // changes by a constant spread over the whole grid.
        let before = params.get(id).clone();
        assert!(w.set_dc_gain(&mut params, 0.09));
        assert!((w.dc_gain(&params).unwrap() - 0.09).abs() < 1e-15);
        let after = params.get(id);
        let changed: Vec<usize> = (0..after.data().len())
            .filter(|&i| after.data()[i] != before.data()[i])
            .collect();
        assert_eq!(
            changed,
            vec![0],
            "only the DC bin's real part changes (its imaginary was 0)"
        );
        let grid = 2 * n - 1;
        let full = w.kernel(&params, grid).unwrap();
        assert!((full.data().iter().sum::<f64>() - 0.09).abs() < 1e-9);
        let shift = (dc - 0.09) / (grid * grid) as f64;
        let k7_after = w.kernel(&params, 7).unwrap();
        for (a, b) in k7_after.data().iter().zip(k.data()) {
            assert!((b - a - shift).abs() < 1e-12, "{a} vs {b}");
        }
    }
}
