//! A retina-free data source for tests and benches: smooth random colour images seen through a
//! fixed random cone mosaic and a fixed lateral-inhibition kernel, shifted by an integer eye
//! motion. The cortex crate has no retina; this stands in for it with the same data contract.
//!
//! Per sample:
//! 1. A `K`-channel image of side `n + 2·margin` (margin = max shift + 1): the sum of `octaves`
//!    white-noise fields blurred by Gaussians of σ, 2σ, 4σ, … (each of unit variance, so the
//!    power spectrum falls like 1/f², as in natural images), channels mixed by a fixed correlated matrix (natural cone
//!    signals are strongly correlated), mapped to `0.5 + 0.25·x`.
//! 2. An integer shift `s = (sx, sy)` uniform in `[−max_shift_px, max_shift_px − 1]`² (official
//!    [−15, 14]). Frame t is the window at offset `margin`, frame t+1 the window at
//!    `margin + s`, so frame t+1 at p shows frame t at p + s (the cortex's sign convention).
//! 3. Cone activation = the channel of the cell's cone type (mosaic drawn once, probabilities
//!    `cone_probabilities`).
//! 4. ONS = the retina's 7×7 difference of Gaussians (`dog_kernel` crate: σ 0.15 and 0.9 px,
//!    surround 0.91, authors' code, docs/references.md#lateral-inhibition) as a
//!    zero-padded linear convolution, unless `lateral_inhibition` is off (the S-05 baseline
//!    "cone activations as ONS").
//! 5. Oracle motion `d = s / motion_px_per_unit` in field units.

use crate::data::{DataSource, OnsBatch};
use crate::rng::CortexRng;
use crate::CortexError;
use serde::{Deserialize, Serialize};

/// Settings of [`SyntheticSource`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SyntheticConfig {
    /// ONS side n.
    pub n: usize,
    /// Probability of each cone type (its length is the number of image channels K).
    pub cone_probabilities: Vec<f64>,
    /// Shifts are drawn from `[−max_shift_px, max_shift_px − 1]` (official: 15).
    pub max_shift_px: i32,
    /// σ of the finest Gaussian that makes the random image smooth, in ONS px.
    pub smooth_sigma_px: f64,
    /// Octaves of smoothed noise summed with equal variance (σ, 2σ, 4σ, …): equal energy per
    /// octave, the 1/f² power spectrum of natural images.
    pub octaves: usize,
    /// Correlation between colour channels, in [0, 1).
    pub channel_correlation: f64,
    /// Apply the DoG lateral inhibition (off: cone activations are the ONS).
    pub lateral_inhibition: bool,
    /// ONS pixels per unit of oracle motion (`(n−1)/2` matches an identity P on the
    /// align-corners grid; `n/2` is the official shift/(R/2) with R = n).
    pub motion_px_per_unit: f64,
    /// Seed of the mosaic and the sample stream.
    pub seed: u64,
}

impl SyntheticConfig {
    /// LMS-like mosaic (.62/.32/.06), shifts in [−15, 14], σ 2 px, DoG on, identity-P units.
    pub fn lms(n: usize, seed: u64) -> Self {
        SyntheticConfig {
            n,
            cone_probabilities: vec![0.62, 0.32, 0.06],
            max_shift_px: 15,
            smooth_sigma_px: 2.0,
            octaves: 4,
            channel_correlation: 0.6,
            lateral_inhibition: true,
            motion_px_per_unit: (n as f64 - 1.0) / 2.0,
            seed,
        }
    }
}

/// The synthetic stream. Its state (the RNG) is saved in checkpoints.
pub struct SyntheticSource {
    cfg: SyntheticConfig,
    mosaic: Vec<u8>,
    rng: CortexRng,
    // scratch
    noise: Vec<f64>,
    tmp: Vec<f64>,
    /// The last batch's integer shifts (sx, sy) in ONS px, for tests.
    pub last_shifts: Vec<[i32; 2]>,
}

/// The official 7×7 lateral-inhibition kernel, Gc(σ 0.15) − 0.91·Gs(σ 0.9), each sums to 1:
/// the retina's kernel ([`dog_kernel::official_kernel`]) as rows.
pub fn dog_kernel_7x7() -> [[f64; 7]; 7] {
    let k = dog_kernel::official_kernel();
    assert_eq!(
        k.len(),
        49,
        "dog_kernel_7x7: official kernel has {} taps",
        k.len()
    );
    std::array::from_fn(|i| std::array::from_fn(|j| k[i * 7 + j]))
}

impl SyntheticSource {
    /// A source with a mosaic drawn from `cfg.seed`.
    pub fn new(cfg: SyntheticConfig) -> Self {
        let mut rng = CortexRng::seed_from(cfg.seed);
        let total: f64 = cfg.cone_probabilities.iter().sum();
        let mosaic = (0..cfg.n * cfg.n)
            .map(|_| {
                let mut u = rng.uniform() * total;
                let mut k = 0;
                while k + 1 < cfg.cone_probabilities.len() && u >= cfg.cone_probabilities[k] {
                    u -= cfg.cone_probabilities[k];
                    k += 1;
                }
                k as u8
            })
            .collect();
        SyntheticSource {
            cfg,
            mosaic,
            rng,
            noise: Vec::new(),
            tmp: Vec::new(),
            last_shifts: Vec::new(),
        }
    }

    /// The cone type of each cell, `n·n` row-major.
    pub fn mosaic(&self) -> &[u8] {
        &self.mosaic
    }

    /// The settings.
    pub fn config(&self) -> &SyntheticConfig {
        &self.cfg
    }

    /// One smooth image of side `side` with `k` channels, `(k, side, side)`.
    fn smooth_image(&mut self, side: usize, k: usize, out: &mut Vec<f64>) {
        out.clear();
        out.resize(k * side * side, 0.0);
        let octaves = self.cfg.octaves.max(1);
        for o in 0..octaves {
            let sigma = self.cfg.smooth_sigma_px * (1u64 << o) as f64;
            let r = (3.0 * sigma).ceil() as isize;
            let taps: Vec<f64> = (-r..=r)
                .map(|i| (-(i * i) as f64 / (2.0 * sigma * sigma)).exp())
                .collect();
            // unit output variance per pass, and equal variance per octave overall
            let norm =
                taps.iter().map(|t| t * t).sum::<f64>().sqrt() * (octaves as f64).sqrt().sqrt();
            let ext = side + 2 * r as usize;
            for c in 0..k {
                self.noise.clear();
                for _ in 0..ext * ext {
                    let v = self.rng.normal();
                    self.noise.push(v);
                }
                // rows then columns, valid region only
                self.tmp.clear();
                self.tmp.resize(ext * side, 0.0);
                for y in 0..ext {
                    for x in 0..side {
                        let mut s = 0.0;
                        for (t, w) in taps.iter().enumerate() {
                            s += w * self.noise[y * ext + x + t];
                        }
                        self.tmp[y * side + x] = s / norm;
                    }
                }
                for y in 0..side {
                    for x in 0..side {
                        let mut s = 0.0;
                        for (t, w) in taps.iter().enumerate() {
                            s += w * self.tmp[(y + t) * side + x];
                        }
                        out[(c * side + y) * side + x] += s / norm;
                    }
                }
            }
        }
        // correlate channels: channel c = √ρ·shared + √(1−ρ)·own, shared = channel 0.
        let rho = self.cfg.channel_correlation;
        let plane = side * side;
        for c in 1..k {
            for i in 0..plane {
                out[c * plane + i] = rho.sqrt() * out[i] + (1.0 - rho).sqrt() * out[c * plane + i];
            }
        }
        out.iter_mut().for_each(|v| *v = 0.5 + 0.25 * *v);
    }
}

impl DataSource for SyntheticSource {
    fn next_batch_into(&mut self, batch_size: usize, out: &mut OnsBatch) {
        let n = self.cfg.n;
        let k = self.cfg.cone_probabilities.len();
        let m = self.cfg.max_shift_px.max(0) as usize + 1;
        let side = n + 2 * m;
        out.ons.clear();
        out.ons.resize(batch_size * 2 * n * n, 0.0);
        let ons = &mut out.ons;
        let mut motion = Vec::with_capacity(batch_size);
        self.last_shifts.clear();
        let mut img = Vec::new();
        let mut cone = vec![0.0f64; n * n];
        let dog = dog_kernel_7x7();
        for b in 0..batch_size {
            self.smooth_image(side, k, &mut img);
            let lo = -(self.cfg.max_shift_px as i64);
            let hi = (self.cfg.max_shift_px as i64 - 1).max(lo);
            let sx = self.rng.int_in(lo, hi) as isize;
            let sy = self.rng.int_in(lo, hi) as isize;
            self.last_shifts.push([sx as i32, sy as i32]);
            motion.push([
                (sx as f64 / self.cfg.motion_px_per_unit) as f32,
                (sy as f64 / self.cfg.motion_px_per_unit) as f32,
            ]);
            for t in 0..2 {
                let (ox, oy) = if t == 0 {
                    (m as isize, m as isize)
                } else {
                    (m as isize + sx, m as isize + sy)
                };
                for y in 0..n {
                    for x in 0..n {
                        let c = self.mosaic[y * n + x] as usize;
                        cone[y * n + x] = img[(c * side + (y as isize + oy) as usize) * side
                            + (x as isize + ox) as usize];
                    }
                }
                let dst = &mut ons[(b * 2 + t) * n * n..(b * 2 + t + 1) * n * n];
                if self.cfg.lateral_inhibition {
                    for y in 0..n as isize {
                        for x in 0..n as isize {
                            let mut s = 0.0;
                            for (i, row) in dog.iter().enumerate() {
                                let yy = y + i as isize - 3;
                                if yy < 0 || yy >= n as isize {
                                    continue;
                                }
                                for (j, w) in row.iter().enumerate() {
                                    let xx = x + j as isize - 3;
                                    if xx >= 0 && xx < n as isize {
                                        s += w * cone[yy as usize * n + xx as usize];
                                    }
                                }
                            }
                            dst[y as usize * n + x as usize] = s as f32;
                        }
                    }
                } else {
                    for (d, &c) in dst.iter_mut().zip(&cone) {
                        *d = c as f32;
                    }
                }
            }
        }
        out.batch = batch_size;
        out.n = n;
        out.oracle_motion = Some(motion);
    }

    fn save_state(&self) -> Option<serde_json::Value> {
        serde_json::to_value(&self.rng).ok()
    }

    fn load_state(&mut self, state: &serde_json::Value) -> Result<(), CortexError> {
        self.rng = serde_json::from_value(state.clone())
            .map_err(|e| CortexError::DataSourceState(format!("synthetic source RNG: {e}")))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dog_kernel_sums_to_official_dc_gain() {
        let s: f64 = dog_kernel_7x7().iter().flatten().sum();
        assert!((s - 0.09).abs() < 1e-3, "{s}");
    }

    #[test]
    fn frame_t1_is_frame_t_shifted_by_the_oracle_before_inhibition() {
        let mut cfg = SyntheticConfig::lms(24, 3);
        cfg.lateral_inhibition = false;
        cfg.cone_probabilities = vec![1.0];
        let mut src = SyntheticSource::new(cfg);
        let b = src.next_batch(3);
        b.validate().unwrap();
        for s in 0..3 {
            let [sx, sy] = src.last_shifts[s];
            let (f0, f1) = (b.frame(s, 0), b.frame(s, 1));
            let n = 24isize;
            for y in 0..n {
                for x in 0..n {
                    let (x0, y0) = (x + sx as isize, y + sy as isize);
                    if (0..n).contains(&x0) && (0..n).contains(&y0) {
                        assert_eq!(f1[(y * n + x) as usize], f0[(y0 * n + x0) as usize]);
                    }
                }
            }
            let d = b.oracle_motion.as_ref().unwrap()[s];
            assert!((d[0] as f64 * 11.5 - sx as f64).abs() < 1e-5);
        }
    }

    #[test]
    fn state_restores_the_stream() {
        let mut a = SyntheticSource::new(SyntheticConfig::lms(16, 5));
        a.next_batch(2);
        let st = a.save_state().unwrap();
        let want = a.next_batch(2);
        let mut b = SyntheticSource::new(SyntheticConfig::lms(16, 5));
        b.load_state(&st).unwrap();
        assert_eq!(b.next_batch(2), want);
    }
}
