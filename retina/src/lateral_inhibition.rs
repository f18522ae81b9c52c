//! Lateral inhibition: difference-of-Gaussians on the cone lattice (authors' code, docs/references.md#lateral-inhibition, paper S-02).
//!
//! Stage `LateralInhibition::compute(input, out)`:
//! - input: cone activations `(n, n)` row-major f32 (lattice order, not visual space — the
//!   paper's "cone diameters" are lattice pitches);
//! - output: the bipolar signal `(n, n)`, `out = K ⊛ input`, a zero-padded linear ("same")
//!   2-D convolution (the official FFT on a (2n−1)² grid is exactly this).
//!
//! Kernel (defined once, in the `dog_kernel` crate, which the cortex's synthetic source shares):
//! size `ceil(6·σs)` bumped to odd (7 for σs = 0.9); `K = Gc − w·Gs` with Gc, Gs Gaussians of
//! σc = 0.15 and σs = 0.9 cells sampled on the integer offsets, each normalised to sum 1, and
//! w = 0.91, so ΣK = 0.09 (the paper's "non-zero mean 0.09"). Centre tap ≈ 0.821, nearest
//! neighbours ≈ −0.0965, diagonals ≈ −0.052. K is symmetric, so convolution and correlation
//! coincide.
//!
//! Two paths that must agree to 1e-6: direct (49 row AXPYs per output row, the default) and FFT
//! (rustfft, f64, on a padded grid ≥ n + size − 1).
//!
//! Noise after LI: `out ← out · (1 + s · r · ε)`, s = 0.01, ε ~ N(0, 1) per cell, r the batch's
//! noise ratio ([`crate::cones::NoiseConfig`]).

use std::sync::Arc;

use rand::Rng;
use rand_distr::StandardNormal;
use rustfft::num_complex::Complex64;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};

pub use dog_kernel::{
    OFFICIAL_SIGMA_CENTRE_CELLS, OFFICIAL_SIGMA_SURROUND_CELLS, OFFICIAL_SURROUND_WEIGHT,
};

/// Which convolution path.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConvMethod {
    /// Direct spatial convolution.
    Direct,
    /// FFT convolution (f64).
    Fft,
}

/// DoG settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DogConfig {
    /// Centre Gaussian σ, lattice cells.
    pub sigma_centre_cells: f64,
    /// Surround Gaussian σ, lattice cells.
    pub sigma_surround_cells: f64,
    /// Weight of the (unit-sum) surround.
    pub surround_weight: f64,
    /// Convolution path.
    pub method: ConvMethod,
}

impl Default for DogConfig {
    fn default() -> Self {
        DogConfig {
            sigma_centre_cells: OFFICIAL_SIGMA_CENTRE_CELLS,
            sigma_surround_cells: OFFICIAL_SIGMA_SURROUND_CELLS,
            surround_weight: OFFICIAL_SURROUND_WEIGHT,
            method: ConvMethod::Direct,
        }
    }
}

impl DogConfig {
    /// Kernel side: `ceil(6·σs)`, bumped to odd ([`dog_kernel::kernel_size`]).
    pub fn kernel_size(&self) -> usize {
        dog_kernel::kernel_size(self.sigma_surround_cells)
    }

    /// The kernel, `(size, size)` row-major f64 ([`dog_kernel::kernel`]).
    pub fn kernel(&self) -> Vec<f64> {
        dog_kernel::kernel(
            self.sigma_centre_cells,
            self.sigma_surround_cells,
            self.surround_weight,
        )
    }
}

/// The LI stage for one lattice size (kernel and FFT plans precomputed).
pub struct LateralInhibition {
    /// Settings.
    pub config: DogConfig,
    /// Lattice side.
    pub n: usize,
    /// Kernel side.
    pub size: usize,
    /// Kernel `(size, size)`, f64.
    pub kernel: Vec<f64>,
    kernel_f32: Vec<f32>,
    fft_len: usize,
    fft_fwd: Arc<dyn Fft<f64>>,
    fft_inv: Arc<dyn Fft<f64>>,
    kernel_spectrum: Vec<Complex64>,
}

impl std::fmt::Debug for LateralInhibition {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("LateralInhibition")
            .field("config", &self.config)
            .field("n", &self.n)
            .field("size", &self.size)
            .finish()
    }
}

/// In-place 2-D FFT of a `len × len` buffer (rows, then columns through a transpose).
fn fft2(fft: &Arc<dyn Fft<f64>>, buf: &mut [Complex64], tmp: &mut [Complex64], len: usize) {
    fft.process(buf);
    for y in 0..len {
        for x in 0..len {
            tmp[x * len + y] = buf[y * len + x];
        }
    }
    fft.process(tmp);
    for y in 0..len {
        for x in 0..len {
            buf[x * len + y] = tmp[y * len + x];
        }
    }
}

impl LateralInhibition {
    /// Precompute the kernel (and its spectrum for the FFT path) for an `n × n` lattice.
    pub fn new(config: DogConfig, n: usize) -> Self {
        let size = config.kernel_size();
        let kernel = config.kernel();
        let fft_len = n + size - 1;
        let mut planner = FftPlanner::<f64>::new();
        let fft_fwd = planner.plan_fft_forward(fft_len);
        let fft_inv = planner.plan_fft_inverse(fft_len);
        let mut kernel_spectrum = vec![Complex64::new(0.0, 0.0); fft_len * fft_len];
        for y in 0..size {
            for x in 0..size {
                kernel_spectrum[y * fft_len + x] = Complex64::new(kernel[y * size + x], 0.0);
            }
        }
        let mut tmp = vec![Complex64::new(0.0, 0.0); fft_len * fft_len];
        fft2(&fft_fwd, &mut kernel_spectrum, &mut tmp, fft_len);
        LateralInhibition {
            config,
            n,
            size,
            kernel_f32: kernel.iter().map(|&v| v as f32).collect(),
            kernel,
            fft_len,
            fft_fwd,
            fft_inv,
            kernel_spectrum,
        }
    }

    /// Sum of the kernel (the DC gain, 0.09 officially).
    pub fn dc_gain(&self) -> f64 {
        self.kernel.iter().sum()
    }

    fn check(&self, input: &[f32], out: &[f32]) {
        let nn = self.n * self.n;
        assert!(
            input.len() == nn && out.len() == nn,
            "LateralInhibition: input {} and out {} must both be {}×{}",
            input.len(),
            out.len(),
            self.n,
            self.n
        );
    }

    /// Configured path.
    pub fn compute(&self, input: &[f32], out: &mut [f32]) {
        match self.config.method {
            ConvMethod::Direct => self.compute_direct(input, out),
            ConvMethod::Fft => self.compute_fft(input, out),
        }
    }

    /// Direct zero-padded "same" convolution.
    pub fn compute_direct(&self, input: &[f32], out: &mut [f32]) {
        self.check(input, out);
        let (n, size) = (self.n, self.size);
        let r = (size / 2) as isize;
        out.fill(0.0);
        for y in 0..n {
            let orow = &mut out[y * n..(y + 1) * n];
            for ky in 0..size {
                let yy = y as isize + ky as isize - r;
                if yy < 0 || yy >= n as isize {
                    continue;
                }
                let irow = &input[yy as usize * n..(yy as usize + 1) * n];
                for kx in 0..size {
                    let k = self.kernel_f32[ky * size + kx];
                    let dx = kx as isize - r;
                    // out[x] += k · in[x + dx] over the x where x + dx is inside.
                    let x0 = (-dx).max(0) as usize;
                    let x1 = (n as isize - dx).min(n as isize) as usize;
                    let src = &irow[(x0 as isize + dx) as usize..(x1 as isize + dx) as usize];
                    for (o, &s) in orow[x0..x1].iter_mut().zip(src) {
                        *o += k * s;
                    }
                }
            }
        }
    }

    /// FFT path (f64): same result as [`LateralInhibition::compute_direct`].
    pub fn compute_fft(&self, input: &[f32], out: &mut [f32]) {
        self.check(input, out);
        let (n, len) = (self.n, self.fft_len);
        let r = self.size / 2;
        let mut buf = vec![Complex64::new(0.0, 0.0); len * len];
        let mut tmp = vec![Complex64::new(0.0, 0.0); len * len];
        for y in 0..n {
            for x in 0..n {
                buf[y * len + x] = Complex64::new(input[y * n + x] as f64, 0.0);
            }
        }
        fft2(&self.fft_fwd, &mut buf, &mut tmp, len);
        for (b, k) in buf.iter_mut().zip(&self.kernel_spectrum) {
            *b *= k;
        }
        fft2(&self.fft_inv, &mut buf, &mut tmp, len);
        let scale = 1.0 / (len * len) as f64;
        // Full linear convolution index (y + r, x + r) is the "same" output (y, x).
        for y in 0..n {
            for x in 0..n {
                out[y * n + x] = (buf[(y + r) * len + x + r].re * scale) as f32;
            }
        }
    }
}

impl LateralInhibition {
    /// The exact inverse of [`LateralInhibition::compute_direct`]: the activations `out (n, n)`
    /// whose LI output is `ons (n, n)`, by conjugate gradients in f64 on the normal equations
    /// `AᵀA x = Aᵀ y` (A is the zero-padded "same" convolution; its kernel is point-symmetric,
    /// so `Aᵀ = A`). Stops when `‖A x − y‖ ≤ rel_tolerance · ‖y‖` or after `max_iterations`;
    /// returns the relative residual reached. A is well conditioned (its symbol lies between
    /// the DC gain, 0.09 officially, and ≈ 1), so a few tens of iterations reach 1e-7.
    pub fn invert(
        &self,
        ons: &[f32],
        out: &mut [f32],
        rel_tolerance: f64,
        max_iterations: usize,
    ) -> f64 {
        self.check(ons, out);
        let y: Vec<f64> = ons.iter().map(|&v| v as f64).collect();
        let y_norm = y.iter().map(|v| v * v).sum::<f64>().sqrt();
        if y_norm == 0.0 {
            out.fill(0.0);
            return 0.0;
        }
        let apply = |x: &[f64], dst: &mut [f64]| self.apply_f64(x, dst);
        let nn = y.len();
        let mut x = vec![0.0; nn];
        let mut residual = y.clone(); // y − A x
        let mut r = vec![0.0; nn]; // Aᵀ (y − A x)
        apply(&residual, &mut r);
        let mut p = r.clone();
        let (mut q, mut ap) = (vec![0.0; nn], vec![0.0; nn]);
        let mut rr: f64 = r.iter().map(|v| v * v).sum();
        let mut rel = 1.0;
        for _ in 0..max_iterations {
            apply(&p, &mut ap);
            apply(&ap, &mut q);
            let denom: f64 = ap.iter().map(|v| v * v).sum();
            if denom == 0.0 {
                break;
            }
            let step = rr / denom;
            for i in 0..nn {
                x[i] += step * p[i];
                residual[i] -= step * ap[i];
                r[i] -= step * q[i];
            }
            rel = residual.iter().map(|v| v * v).sum::<f64>().sqrt() / y_norm;
            if rel <= rel_tolerance {
                break;
            }
            let rr_next: f64 = r.iter().map(|v| v * v).sum();
            let beta = rr_next / rr;
            rr = rr_next;
            for i in 0..nn {
                p[i] = r[i] + beta * p[i];
            }
        }
        for (o, v) in out.iter_mut().zip(&x) {
            *o = *v as f32;
        }
        rel
    }

    /// [`LateralInhibition::compute_direct`] in f64.
    fn apply_f64(&self, input: &[f64], out: &mut [f64]) {
        let (n, size) = (self.n, self.size);
        let r = (size / 2) as isize;
        out.fill(0.0);
        for y in 0..n as isize {
            for ky in 0..size as isize {
                let yy = y + ky - r;
                if yy < 0 || yy >= n as isize {
                    continue;
                }
                for kx in 0..size as isize {
                    let k = self.kernel[(ky * size as isize + kx) as usize];
                    let dx = kx - r;
                    let x0 = (-dx).max(0);
                    let x1 = (n as isize - dx).min(n as isize);
                    for x in x0..x1 {
                        out[(y * n as isize + x) as usize] +=
                            k * input[(yy * n as isize + x + dx) as usize];
                    }
                }
            }
        }
    }
}

/// `x ← x · (1 + scale · r · ε)` in place (module docs).
pub fn add_multiplicative_noise<R: Rng + ?Sized>(rng: &mut R, x: &mut [f32], scale: f32, r: f32) {
    if r == 0.0 || scale == 0.0 {
        return;
    }
    let s = scale * r;
    for v in x.iter_mut() {
        let e: f32 = rng.sample(StandardNormal);
        *v += *v * s * e;
    }
}

#[cfg(test)]
mod tests;
