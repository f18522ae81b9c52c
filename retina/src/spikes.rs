//! ON/OFF rectification and leaky integrate-and-fire spikes — the optional spiking path.
//!
//! Paper S-02/S-03: ON = ReLU(x), OFF = ReLU(−x) of the laterally inhibited signal x; retinal
//! ganglion cells fire with a leaky integrate-and-fire (LIF) model; the cortex recombines ON and
//! OFF and time-averages, which gives a real-valued image proportional to x. The official
//! training code skips all of this (its spike conversion is the identity), so the analog path
//! is the training default; this module serves pictures, movies and a spiking mode.
//!
//! Stage `Lif::step(bipolar, on_spikes, off_spikes)`, once per frame, for each cell and each of
//! the ON and OFF channels separately (the paper's split; the official tutorial merges them
//! through |x|):
//!
//! ```text
//! V ← decay · V + gain · drive,   spike (1) if V > threshold, then V ← 0
//! ```
//!
//! with decay 0.9 and threshold 0.5 (the official tutorial's `LeakyIntegrateAndFire`; not in the
//! paper) and `drive` = ON or OFF. The input gain (dimensionless, default 4) is ours: the
//! bipolar signal of a white-balanced scene is mostly below 0.1 (the DoG's DC gain is 0.09), and
//! with gain 1 it would rarely reach the threshold. For a constant drive u the LIF fires every
//! k frames, k the smallest integer with `u·(1 − decay^k)/(1 − decay) > threshold`; rates are
//! zero below `threshold·(1 − decay)` = 0.05 and saturate at 1 above 0.5.
//!
//! Shapes: all buffers `(n, n)` row-major f32; spikes are 0.0 or 1.0. [`SpikeAverager`]
//! accumulates `ON − OFF` spikes over frames; its mean is the time-averaged optic nerve signal.

use serde::{Deserialize, Serialize};

/// Membrane decay per frame (official tutorial, authors' code, docs/references.md#spikes).
pub const OFFICIAL_LIF_DECAY: f32 = 0.9;
/// Firing threshold (official tutorial, authors' code, docs/references.md#spikes).
pub const OFFICIAL_LIF_THRESHOLD: f32 = 0.5;
/// Input gain from the bipolar signal to the LIF drive (ours; module docs).
pub const DEFAULT_LIF_DRIVE_GAIN: f32 = 4.0;

/// LIF settings.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LifConfig {
    /// V ← decay·V + …
    pub decay: f32,
    /// Spike when V > threshold.
    pub threshold: f32,
    /// Gain on the rectified bipolar drive.
    pub drive_gain: f32,
}

impl Default for LifConfig {
    fn default() -> Self {
        LifConfig {
            decay: OFFICIAL_LIF_DECAY,
            threshold: OFFICIAL_LIF_THRESHOLD,
            drive_gain: DEFAULT_LIF_DRIVE_GAIN,
        }
    }
}

/// ON = max(x, 0), OFF = max(−x, 0).
pub fn on_off(bipolar: &[f32], on: &mut [f32], off: &mut [f32]) {
    assert!(
        on.len() == bipolar.len() && off.len() == bipolar.len(),
        "on_off: bipolar {}, on {}, off {}",
        bipolar.len(),
        on.len(),
        off.len()
    );
    for ((x, a), b) in bipolar.iter().zip(on.iter_mut()).zip(off.iter_mut()) {
        *a = x.max(0.0);
        *b = (-x).max(0.0);
    }
}

/// Membrane state of the ON and OFF ganglion cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Lif {
    /// Settings.
    pub config: LifConfig,
    /// ON membrane potentials.
    pub v_on: Vec<f32>,
    /// OFF membrane potentials.
    pub v_off: Vec<f32>,
}

impl Lif {
    /// Resting state (V = 0) for `cells` cells.
    pub fn new(config: LifConfig, cells: usize) -> Self {
        Lif {
            config,
            v_on: vec![0.0; cells],
            v_off: vec![0.0; cells],
        }
    }

    /// One frame (module docs). Writes 0/1 spikes.
    pub fn step(&mut self, bipolar: &[f32], on_spikes: &mut [f32], off_spikes: &mut [f32]) {
        let n = self.v_on.len();
        assert!(
            bipolar.len() == n && on_spikes.len() == n && off_spikes.len() == n,
            "Lif::step: state {n}, bipolar {}, on {}, off {}",
            bipolar.len(),
            on_spikes.len(),
            off_spikes.len()
        );
        let LifConfig {
            decay,
            threshold,
            drive_gain,
        } = self.config;
        let fire = |v: &mut f32, drive: f32| -> f32 {
            *v = decay * *v + drive_gain * drive;
            if *v > threshold {
                *v = 0.0;
                1.0
            } else {
                0.0
            }
        };
        for i in 0..n {
            let x = bipolar[i];
            on_spikes[i] = fire(&mut self.v_on[i], x.max(0.0));
            off_spikes[i] = fire(&mut self.v_off[i], (-x).max(0.0));
        }
    }
}

/// Running sums of ON − OFF spikes (the cortex's time average, paper S-03).
#[derive(Debug, Clone, PartialEq)]
pub struct SpikeAverager {
    sum: Vec<f32>,
    frames: usize,
}

impl SpikeAverager {
    /// Empty averager for `cells` cells.
    pub fn new(cells: usize) -> Self {
        SpikeAverager {
            sum: vec![0.0; cells],
            frames: 0,
        }
    }

    /// Add one frame of spikes.
    pub fn add(&mut self, on_spikes: &[f32], off_spikes: &[f32]) {
        for ((s, a), b) in self.sum.iter_mut().zip(on_spikes).zip(off_spikes) {
            *s += a - b;
        }
        self.frames += 1;
    }

    /// Frames added so far.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Mean ON − OFF spike count per frame, `(n, n)`, in [−1, 1].
    pub fn mean(&self) -> Vec<f32> {
        let f = self.frames.max(1) as f32;
        self.sum.iter().map(|s| s / f).collect()
    }
}

/// Steady-state firing rate (spikes/frame) of one LIF channel for a constant drive `u ≥ 0`.
pub fn steady_rate(config: &LifConfig, u: f32) -> f32 {
    let g = config.drive_gain * u;
    let mut v = 0.0f32;
    for k in 1..=10_000 {
        v = config.decay * v + g;
        if v > config.threshold {
            return 1.0 / k as f32;
        }
    }
    0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn on_off_split_recombines() {
        let x = [-0.3f32, 0.0, 0.2];
        let (mut a, mut b) = ([0.0; 3], [0.0; 3]);
        on_off(&x, &mut a, &mut b);
        assert_eq!(a, [0.0, 0.0, 0.2]);
        assert_eq!(b, [0.3, 0.0, 0.0]);
        for i in 0..3 {
            assert_eq!(a[i] - b[i], x[i]);
        }
    }

    #[test]
    fn lif_fires_at_the_predicted_rate_and_signs_split() {
        let cfg = LifConfig {
            drive_gain: 1.0,
            ..LifConfig::default()
        };
        // u = 0.2: V = 0.2, 0.38, 0.542 → spike every 3rd frame.
        assert_eq!(steady_rate(&cfg, 0.2), 1.0 / 3.0);
        assert_eq!(steady_rate(&cfg, 0.6), 1.0);
        assert_eq!(steady_rate(&cfg, 0.049), 0.0);
        let mut lif = Lif::new(cfg, 2);
        let mut avg = SpikeAverager::new(2);
        let (mut on, mut off) = ([0.0; 2], [0.0; 2]);
        for _ in 0..300 {
            lif.step(&[0.2, -0.2], &mut on, &mut off);
            avg.add(&on, &off);
        }
        let m = avg.mean();
        assert!((m[0] - 1.0 / 3.0).abs() < 1e-6 && (m[1] + 1.0 / 3.0).abs() < 1e-6);
    }
}
