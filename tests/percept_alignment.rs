//! `colorvision percept-alignment`: a run against itself is aligned exactly (R² and CKA 1 at
//! every common step), against a run of another learning rate through the same eye less so;
//! runs through different eyes are refused naming `retina`, and nothing is written.

mod common;

use common::{colorvision, text};

fn train(dir: &std::path::Path, out: &str, learning_rate: &str, cones: &str) {
    let rate = format!("cortex.train.learning_rate={learning_rate}");
    let args = [
        "train",
        "--preset",
        "tiny",
        "--cones",
        cones,
        "--steps",
        "4",
        "--seed",
        "1",
        "--set",
        "cortex.train.checkpoint_every_steps=2",
        "--set",
        &rate,
        "--out",
        out,
    ];
    let o = colorvision(dir, &args);
    assert!(o.status.success(), "{}", text(&o));
}

/// `(step, r2_b_from_a, r2_a_from_b, cka)` rows of a written CSV.
fn rows(path: &std::path::Path) -> Vec<[f64; 4]> {
    let csv = std::fs::read_to_string(path).unwrap();
    csv.lines()
        .skip(1)
        .map(|l| {
            let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
            [v[0], v[1], v[2], v[3]]
        })
        .collect()
}

#[test]
fn a_run_is_aligned_with_itself_and_less_with_another_learning_rate() {
    let dir = std::env::temp_dir().join(format!("cv_percept_alignment_{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    train(&dir, "a", "1e-3", "LMS");
    train(&dir, "b", "1e-2", "LMS");
    let run = |against: &str| {
        colorvision(
            &dir,
            &[
                "percept-alignment",
                "--run",
                "a",
                "--against",
                against,
                "--batches",
                "1",
            ],
        )
    };
    let o = run("a");
    assert!(o.status.success(), "{}", text(&o));
    let same = rows(&dir.join("a/percept-alignment/against-a.csv"));
    assert_eq!(same.iter().map(|r| r[0]).collect::<Vec<_>>(), [2.0, 4.0]);
    for r in &same {
        assert!(r[1..].iter().all(|v| (v - 1.0).abs() < 1e-6), "{r:?}");
    }
    let o = run("b");
    assert!(o.status.success(), "{}", text(&o));
    let other = rows(&dir.join("a/percept-alignment/against-b.csv"));
    assert_eq!(other.len(), 2);
    // Another learning rate: neither percept is an affine function of the other.
    assert!(
        other
            .iter()
            .all(|r| r[1] < 1.0 - 1e-6 && r[2] < 1.0 - 1e-6 && r[3] < 1.0 - 1e-6),
        "{other:?}"
    );

    // Another eye: refused before anything is written.
    train(&dir, "c", "1e-3", "LM");
    let o = run("c");
    assert!(!o.status.success());
    assert!(text(&o).contains("retina"), "{}", text(&o));
    assert!(!dir.join("a/percept-alignment/against-c.csv").exists());
    std::fs::remove_dir_all(dir).ok();
}
