//! CMF-SIM's verdict over several checkpoints of one run: how often each dimension came out,
//! and per K how many of the checkpoints that tried K passed it and the range of its margin
//! (converged worst error / threshold of the best set; pass < 1).
//!
//! One checkpoint's dimension can flip between neighbours when a margin sits near 1; the
//! verdict is *settled* only when every checkpoint measured gives the same dimension, and
//! *on the border* between d and d + 1 otherwise (d the lowest dimension seen). Checkpoints
//! near the end of training are the ones to ask (`convergence --cmf-steps`).

use super::StudyRow;
use std::collections::BTreeMap;
use std::fmt::Write as _;

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

/// The verdict over the checkpoints that carry CMF-SIM.
#[derive(Clone, Debug, PartialEq)]
pub struct VerdictOverCheckpoints {
    /// Steps of those checkpoints, ascending.
    pub steps: Vec<u64>,
    /// Dimension → how many checkpoints gave it (0: undefined).
    pub dimensions: BTreeMap<usize, usize>,
    /// Per K tried, in K order.
    pub per_k: Vec<KOverCheckpoints>,
}

impl VerdictOverCheckpoints {
    /// The verdict over `rows`; `None` when fewer than two carry CMF-SIM.
    pub fn of(rows: &[StudyRow]) -> Option<Self> {
        let measured: Vec<(u64, &super::CmfPoint)> = rows
            .iter()
            .filter_map(|r| r.cmf.as_ref().map(|c| (r.step, c)))
            .collect();
        if measured.len() < 2 {
            return None;
        }
        let mut steps: Vec<u64> = measured.iter().map(|(s, _)| *s).collect();
        steps.sort_unstable();
        let mut dimensions = BTreeMap::new();
        let mut per_k: BTreeMap<usize, KOverCheckpoints> = BTreeMap::new();
        for (_, cmf) in &measured {
            *dimensions.entry(cmf.dimension).or_insert(0) += 1;
            for &[k, passed, margin] in &cmf.per_k {
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
            steps,
            dimensions,
            per_k: per_k.into_values().collect(),
        })
    }

    /// Every checkpoint gave the same dimension.
    pub fn settled(&self) -> bool {
        self.dimensions.len() == 1
    }

    /// In words, e.g. "CMF-SIM at 4 checkpoints (steps 34000–40000): 3-D at 3, 4-D at 1 — on
    /// the border between 3 and 4, not settled. Per K, passed at how many of the checkpoints
    /// that tried it (margin range): K1 0 of 4 (9.1–10.4), …".
    pub fn describe(&self) -> String {
        let n = self.steps.len();
        let mut s = format!(
            "CMF-SIM at {n} checkpoints (steps {}–{}): ",
            self.steps[0],
            self.steps[n - 1]
        );
        let counts: Vec<String> = self
            .dimensions
            .iter()
            .map(|(d, c)| format!("{} at {c}", dimension_name(*d)))
            .collect();
        if self.settled() {
            let d = *self.dimensions.keys().next().expect("one dimension");
            let _ = write!(s, "{} at all {n} — settled. ", dimension_name(d));
        } else {
            let lowest = *self.dimensions.keys().next().expect("dimensions");
            let _ = write!(
                s,
                "{} — on the border between {lowest} and {}, not settled. ",
                counts.join(", "),
                lowest + 1
            );
        }
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
mod tests {
    use super::*;
    use crate::convergence::CmfPoint;

    fn cmf(dimension: usize, per_k: &[(usize, bool, f64)]) -> CmfPoint {
        CmfPoint {
            dimension,
            base_over_energy: 0.01,
            per_k: per_k
                .iter()
                .map(|&(k, p, m)| [k as f64, f64::from(u8::from(p)), m])
                .collect(),
            seconds: 1.0,
        }
    }

    fn rows_at(steps: &[u64]) -> Vec<StudyRow> {
        let p = crate::invariants::PRecovery {
            spacing_r: 0.9,
            position_error_rms_cones: 0.3,
            position_error_median_cones: 0.2,
        };
        let recovery = crate::invariants::Recovery {
            c: None,
            w: None,
            p,
            hidden: None,
            directions: None,
        };
        steps
            .iter()
            .map(|&step| StudyRow {
                step,
                heldout_gain: None,
                wall_seconds: None,
                recovery: recovery.clone(),
                held_out_scenes: 32,
                cmf: None,
            })
            .collect()
    }

    fn with_cmf(rows: &mut [StudyRow], points: Vec<Option<CmfPoint>>) {
        for (r, c) in rows.iter_mut().zip(points) {
            r.cmf = c;
        }
    }

    #[test]
    fn needs_two_checkpoints_with_cmf() {
        let mut rows = rows_at(&[1000, 2000]);
        with_cmf(&mut rows, vec![Some(cmf(3, &[(3, true, 0.5)])), None]);
        assert_eq!(VerdictOverCheckpoints::of(&rows), None);
    }

    #[test]
    fn a_flip_is_the_border_and_counts_each_k() {
        let mut rows = rows_at(&[40000, 34000, 36000]);
        with_cmf(
            &mut rows,
            vec![
                Some(cmf(3, &[(1, false, 9.0), (2, false, 1.3), (3, true, 0.96)])),
                Some(cmf(
                    4,
                    &[
                        (1, false, 10.0),
                        (2, false, 1.2),
                        (3, false, 1.02),
                        (4, true, 0.4),
                    ],
                )),
                Some(cmf(3, &[(1, false, 9.5), (2, false, 1.4), (3, true, 0.99)])),
            ],
        );
        let v = VerdictOverCheckpoints::of(&rows).expect("three measured");
        assert_eq!(v.steps, vec![34000, 36000, 40000]);
        assert!(!v.settled());
        assert_eq!(v.dimensions, BTreeMap::from([(3, 2), (4, 1)]));
        let k3 = &v.per_k[2];
        assert_eq!((k3.k, k3.tried, k3.passed), (3, 3, 2));
        assert_eq!((k3.margin_min, k3.margin_max), (0.96, 1.02));
        assert_eq!((v.per_k[3].tried, v.per_k[3].passed), (1, 1));
        let words = v.describe();
        assert!(
            words.contains("3-D at 2, 4-D at 1 — on the border between 3 and 4, not settled"),
            "{words}"
        );
        assert!(words.contains("K3 2 of 3 (0.96–1.02)"), "{words}");
        assert!(words.contains("K4 1 of 1 (0.40)."), "{words}");
    }

    #[test]
    fn the_same_dimension_everywhere_is_settled() {
        let mut rows = rows_at(&[1000, 2000]);
        let three = || Some(cmf(3, &[(2, false, 1.5), (3, true, 0.6)]));
        with_cmf(&mut rows, vec![three(), three()]);
        let v = VerdictOverCheckpoints::of(&rows).expect("two measured");
        assert!(v.settled());
        assert!(
            v.describe().contains("3-D at all 2 — settled"),
            "{}",
            v.describe()
        );
    }
}
