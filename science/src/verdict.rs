//! CMF-SIM's verdict over several checkpoints of one run (and its own final measurement, where
//! it finished: [`VerdictOverCheckpoints::with_final`]): the dimension at each, in step order,
//! and per K how many of the checkpoints that tried K passed it and the range of its margin
//! (converged worst error / threshold of the best set; pass < 1).
//!
//! One checkpoint's dimension can flip between neighbours when a margin sits near 1. Read in
//! step order, the dimensions are *settled* when every checkpoint gives the same one, *rising*
//! (or *falling*) when they only go one way — still learning at these steps — and *on the
//! border* when they go up and down. Checkpoints near the end of training are the ones to ask
//! (`convergence --cmf --cmf-steps`).

use crate::invariants::{self, Recovery};
use crate::summary::Summary;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// The file in a convergence folder (and in a run's record) holding the CMF-SIM of every
/// checkpoint measured, a JSON list of [`CheckpointCmf`].
pub const CMF_FILE: &str = "cmf_over_checkpoints.json";

/// CMF-SIM at one checkpoint, as the verdict reads it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CheckpointCmf {
    /// Training step of the checkpoint.
    pub step: u64,
    /// Colour dimensionality (0: undefined).
    pub dimension: usize,
    /// Per K tried: `[K, passed (0/1), converged worst error/threshold of its best set]`.
    pub per_k: Vec<[f64; 3]>,
}

impl CheckpointCmf {
    /// A run's own final measurement: `dimension` at `step`, per K `(K, margin)` as
    /// `summary.json` keeps them; the K equal to the dimension is the one that passed.
    pub fn from_final(step: u64, dimension: usize, per_k: &[(usize, f64)]) -> Self {
        let per_k = per_k
            .iter()
            .map(|&(k, margin)| [k as f64, f64::from(u8::from(k == dimension)), margin])
            .collect();
        Self {
            step,
            dimension,
            per_k,
        }
    }

    /// The final measurement of the run `summary` describes; `None` when it measured none.
    pub fn final_of(summary: &Summary) -> Option<Self> {
        (!summary.dimension_over_steps.is_empty()).then(|| {
            Self::from_final(
                summary.steps,
                summary.dimension,
                &summary.converged_ratio_per_k,
            )
        })
    }
}

/// CMF-SIM at one checkpoint, in brief.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct CmfPoint {
    /// Colour dimensionality (0: undefined).
    pub dimension: usize,
    /// Σ base error / Σ percept energy (≥ 1: no colour constancy).
    pub base_over_energy: f64,
    /// Per K tried: `[K, passed (0/1), converged worst error/threshold of its best set]`.
    pub per_k: Vec<[f64; 3]>,
    /// Wall time of the measurement, s.
    pub seconds: f64,
}

/// Everything measured at one checkpoint.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StudyRow {
    /// Training step of the checkpoint.
    pub step: u64,
    /// Held-out prediction error of "next = current" over the model's, logged by the run at
    /// the last evaluation at or before `step`.
    pub heldout_gain: Option<f64>,
    /// Wall time of training up to the checkpoint, s, as the run recorded it.
    pub wall_seconds: Option<f64>,
    /// The learned invariants.
    pub recovery: Recovery,
    /// Held-out scenes behind the hidden and direction R² (rows kept from before the count was
    /// recorded used [`invariants::HELD_OUT_SCENES`]).
    #[serde(default = "default_held_out_scenes")]
    pub held_out_scenes: usize,
    /// Whether those scenes came from [`crate::heldout::hidden_source`], a fresh tile every
    /// batch (rows kept from before it: the held-out eye's pool of reused tiles).
    #[serde(default)]
    pub fresh_tiles: bool,
    /// The calibrated CMF-SIM (with `--cmf`).
    pub cmf: Option<CmfPoint>,
}

fn default_held_out_scenes() -> usize {
    invariants::HELD_OUT_SCENES
}

/// Per K: checkpoints that tried it, how many passed, lowest and highest margin.
#[derive(Clone, Debug, PartialEq)]
pub struct KOverCheckpoints {
    /// Number of primaries.
    pub k: usize,
    /// Checkpoints whose CMF-SIM tried this K.
    pub tried: usize,
    /// Of those, the ones where it passed.
    pub passed: usize,
    /// Lowest converged worst error / threshold.
    pub margin_min: f64,
    /// Highest converged worst error / threshold.
    pub margin_max: f64,
}

/// How the dimension moved over the checkpoints, in step order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reading {
    /// The same dimension at every checkpoint.
    Settled(usize),
    /// Never lower than at the checkpoint before, higher at the last than at the first: still
    /// gaining dimensions at these steps (later checkpoints say whether it stays).
    Rising,
    /// Never higher than at the checkpoint before, lower at the last than at the first.
    Falling,
    /// Up and down between these dimensions: a margin near 1 that falls on either side.
    Border {
        /// The lowest dimension seen.
        lowest: usize,
        /// The highest dimension seen.
        highest: usize,
    },
}

/// The verdict over the checkpoints that carry CMF-SIM.
#[derive(Clone, Debug, PartialEq)]
pub struct VerdictOverCheckpoints {
    /// Steps of those checkpoints, ascending.
    pub steps: Vec<u64>,
    /// The dimension at each of `steps` (0: undefined).
    pub dimensions: Vec<usize>,
    /// Per K tried, in K order.
    pub per_k: Vec<KOverCheckpoints>,
}

impl VerdictOverCheckpoints {
    /// The verdict over `rows`; `None` when fewer than two carry CMF-SIM.
    pub fn of(rows: &[StudyRow]) -> Option<Self> {
        Self::from_points(Self::points_of(rows))
    }

    /// The CMF-SIM of `rows` as points, in their order.
    pub fn points_of(rows: &[StudyRow]) -> Vec<CheckpointCmf> {
        rows.iter()
            .filter_map(|r| {
                r.cmf.as_ref().map(|c| CheckpointCmf {
                    step: r.step,
                    dimension: c.dimension,
                    per_k: c.per_k.clone(),
                })
            })
            .collect()
    }

    /// The verdict over `points` (any order; a step given twice counts once, its first);
    /// `None` when fewer than two steps.
    pub fn from_points(mut points: Vec<CheckpointCmf>) -> Option<Self> {
        points.sort_by_key(|p| p.step);
        points.dedup_by_key(|p| p.step);
        if points.len() < 2 {
            return None;
        }
        let mut per_k: BTreeMap<usize, KOverCheckpoints> = BTreeMap::new();
        for point in &points {
            for &[k, passed, margin] in &point.per_k {
                let k = k as usize;
                let e = per_k.entry(k).or_insert(KOverCheckpoints {
                    k,
                    tried: 0,
                    passed: 0,
                    margin_min: f64::INFINITY,
                    margin_max: f64::NEG_INFINITY,
                });
                e.tried += 1;
                e.passed += usize::from(passed > 0.5);
                e.margin_min = e.margin_min.min(margin);
                e.margin_max = e.margin_max.max(margin);
            }
        }
        Some(Self {
            steps: points.iter().map(|p| p.step).collect(),
            dimensions: points.iter().map(|p| p.dimension).collect(),
            per_k: per_k.into_values().collect(),
        })
    }

    /// The verdict over the checkpoints' `points` up to the run's `last` measurement and that
    /// measurement itself, which stands for its step (checkpoints past it, trained after the
    /// run ended, are left out); without `last`, over `points` alone.
    pub fn with_final(mut points: Vec<CheckpointCmf>, last: Option<CheckpointCmf>) -> Option<Self> {
        if let Some(last) = last {
            points.retain(|p| p.step <= last.step);
            points.insert(0, last);
        }
        Self::from_points(points)
    }

    /// How the dimension moved over the checkpoints.
    pub fn reading(&self) -> Reading {
        let d = &self.dimensions;
        let (lowest, highest) = (
            *d.iter().min().expect("two or more"),
            *d.iter().max().expect("two or more"),
        );
        if lowest == highest {
            Reading::Settled(lowest)
        } else if d.windows(2).all(|w| w[0] <= w[1]) {
            Reading::Rising
        } else if d.windows(2).all(|w| w[0] >= w[1]) {
            Reading::Falling
        } else {
            Reading::Border { lowest, highest }
        }
    }

    /// The reading in a few words for a table cell, e.g. "3, 3, 4, 3 at 34 000–40 000 steps:
    /// on the border".
    pub fn brief(&self) -> String {
        let dims: Vec<String> = self.dimensions.iter().map(|d| d.to_string()).collect();
        let reading = match self.reading() {
            Reading::Settled(_) => "settled",
            Reading::Rising => "rising",
            Reading::Falling => "falling",
            Reading::Border { .. } => "on the border",
        };
        let group = |n: u64| crate::summary::digits_grouped(n, ' ');
        format!(
            "{} at {}–{} steps: {reading}",
            dims.join(", "),
            group(self.steps[0]),
            group(self.steps[self.steps.len() - 1])
        )
    }

    /// In words, e.g. "CMF-SIM at 4 checkpoints (steps 34000–40000): 3-D, 3-D, 4-D, 3-D — on
    /// the border between 3-D and 4-D, not settled. Per K, passed at how many of the
    /// checkpoints that tried it (margin range): K1 0 of 4 (9.40–16.43), …".
    pub fn describe(&self) -> String {
        let n = self.steps.len();
        let in_order: Vec<String> = self.dimensions.iter().map(|&d| dimension_name(d)).collect();
        let mut s = format!(
            "CMF-SIM at {n} checkpoints (steps {}–{}): {} — ",
            self.steps[0],
            self.steps[n - 1],
            in_order.join(", ")
        );
        s += &match self.reading() {
            Reading::Settled(d) => format!("{} at all {n}, settled. ", dimension_name(d)),
            Reading::Rising => "rising, not settled: later checkpoints say where it stays. ".into(),
            Reading::Falling => "falling, not settled. ".into(),
            Reading::Border { lowest, highest } => format!(
                "on the border between {} and {}, not settled. ",
                dimension_name(lowest),
                dimension_name(highest)
            ),
        };
        let ks: Vec<String> = self
            .per_k
            .iter()
            .map(|k| {
                let (low, high) = (
                    format!("{:.2}", k.margin_min),
                    format!("{:.2}", k.margin_max),
                );
                let range = if low == high {
                    low
                } else {
                    format!("{low}–{high}")
                };
                format!("K{} {} of {} ({range})", k.k, k.passed, k.tried)
            })
            .collect();
        let _ = write!(
            s,
            "Per K, passed at how many of the checkpoints that tried it (margin range): {}.",
            ks.join(", ")
        );
        s
    }
}

fn dimension_name(d: usize) -> String {
    if d == 0 {
        "undefined".into()
    } else {
        format!("{d}-D")
    }
}

#[cfg(test)]
mod tests;
