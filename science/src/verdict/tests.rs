use super::*;

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
            fresh_tiles: true,
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
            Some(cmf(3, &[(1, false, 9.5), (2, false, 1.4), (3, true, 0.99)])),
            Some(cmf(
                4,
                &[
                    (1, false, 10.0),
                    (2, false, 1.2),
                    (3, false, 1.02),
                    (4, true, 0.4),
                ],
            )),
        ],
    );
    let v = VerdictOverCheckpoints::of(&rows).expect("three measured");
    assert_eq!(v.steps, vec![34000, 36000, 40000]);
    assert_eq!(v.dimensions, vec![3, 4, 3]);
    assert_eq!(
        v.reading(),
        Reading::Border {
            lowest: 3,
            highest: 4
        }
    );
    let k3 = &v.per_k[2];
    assert_eq!((k3.k, k3.tried, k3.passed), (3, 3, 2));
    assert_eq!((k3.margin_min, k3.margin_max), (0.96, 1.02));
    assert_eq!((v.per_k[3].tried, v.per_k[3].passed), (1, 1));
    let words = v.describe();
    assert!(
        words.contains("3-D, 4-D, 3-D — on the border between 3-D and 4-D, not settled"),
        "{words}"
    );
    assert!(words.contains("K3 2 of 3 (0.96–1.02)"), "{words}");
    assert!(words.contains("K4 1 of 1 (0.40)."), "{words}");
}

#[test]
fn one_way_is_rising_or_falling_not_a_border() {
    let mut rows = rows_at(&[1000, 2000, 3000]);
    let at = |d: usize| Some(cmf(d, &[(d, true, 0.5)]));
    with_cmf(&mut rows, vec![at(2), at(3), at(3)]);
    let v = VerdictOverCheckpoints::of(&rows).expect("three measured");
    assert_eq!(v.reading(), Reading::Rising);
    assert!(
        v.describe().contains("2-D, 3-D, 3-D — rising"),
        "{}",
        v.describe()
    );
    with_cmf(&mut rows, vec![at(3), at(3), at(2)]);
    let v = VerdictOverCheckpoints::of(&rows).expect("three measured");
    assert_eq!(v.reading(), Reading::Falling);
}

#[test]
fn the_same_dimension_everywhere_is_settled() {
    let mut rows = rows_at(&[1000, 2000]);
    let three = || Some(cmf(3, &[(2, false, 1.5), (3, true, 0.6)]));
    with_cmf(&mut rows, vec![three(), three()]);
    let v = VerdictOverCheckpoints::of(&rows).expect("two measured");
    assert_eq!(v.reading(), Reading::Settled(3));
    assert!(
        v.describe().contains("3-D, 3-D — 3-D at all 2, settled"),
        "{}",
        v.describe()
    );
}

/// The run's final measurement stands for its step, checkpoints past it are left out, and
/// without it the checkpoints alone are read.
#[test]
fn the_final_measurement_joins_the_checkpoints() {
    let at = |step, dimension: usize, margin| CheckpointCmf {
        step,
        dimension,
        per_k: vec![[dimension as f64, 1.0, margin]],
    };
    let points = vec![at(36_000, 3, 0.84), at(40_000, 4, 0.80), at(44_000, 4, 0.7)];
    let last = CheckpointCmf::from_final(40_000, 3, &[(2, 1.35), (3, 0.96)]);
    assert_eq!(last.per_k, vec![[2.0, 0.0, 1.35], [3.0, 1.0, 0.96]]);
    let v = VerdictOverCheckpoints::with_final(points.clone(), Some(last)).expect("two steps");
    assert_eq!(v.steps, vec![36_000, 40_000]);
    assert_eq!(v.dimensions, vec![3, 3]);
    assert_eq!(v.reading(), Reading::Settled(3));
    let v = VerdictOverCheckpoints::with_final(points, None).expect("three steps");
    assert_eq!(v.dimensions, vec![3, 4, 4]);
    assert_eq!(v.reading(), Reading::Rising);
    let alone = CheckpointCmf::from_final(40_000, 3, &[(3, 0.96)]);
    assert_eq!(
        VerdictOverCheckpoints::with_final(vec![], Some(alone)),
        None
    );
}
