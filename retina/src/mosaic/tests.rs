//! Mosaic fractions and every variant's counts.

use super::*;

const N: usize = 256;
const SEED: u64 = 0;

fn fractions(text: &str) -> (Mosaic, Vec<(String, f64)>) {
    let m = Mosaic::from_spec_str(text, N, SEED).unwrap();
    let f = m
        .classes
        .iter()
        .map(|c| c.name.clone())
        .zip(m.class_fractions())
        .collect();
    (m, f)
}

fn frac(f: &[(String, f64)], name: &str) -> f64 {
    f.iter()
        .find(|(n, _)| n == name)
        .map(|(_, v)| *v)
        .unwrap_or(0.0)
}

#[test]
fn lms_fractions_match_official_at_256() {
    let (m, f) = fractions("LMS");
    eprintln!("LMS fractions at 256²: {f:?}");
    assert_eq!(
        m.classes.iter().map(|c| c.peak_nm).collect::<Vec<_>>(),
        [560.0, 530.0, 419.0]
    );
    for (name, target) in [("L", 0.62), ("M", 0.32), ("S", 0.05)] {
        assert!(
            (frac(&f, name) - target).abs() <= 0.02,
            "{name}: {}",
            frac(&f, name)
        );
    }
    // Pure mosaic: every weight is 0 or 1.
    assert!(m.weights.iter().all(|&w| w == 0.0 || w == 1.0));
}

#[test]
fn no_two_s_cones_share_an_exclusion_window() {
    let m = Mosaic::from_spec_str("LMS", 64, 7).unwrap();
    let s = m.class_index("S").unwrap();
    let dom = m.dominant_class();
    let pos: Vec<(i64, i64)> = (0..64 * 64)
        .filter(|&c| dom[c] == s)
        .map(|c| ((c / 64) as i64, (c % 64) as i64))
        .collect();
    for (a, &(i, j)) in pos.iter().enumerate() {
        for &(p, q) in &pos[a + 1..] {
            // The later of two S cones checked offsets [−3, 2]² around itself, so whatever
            // the visiting order no two S cones lie within Chebyshev distance 2.
            assert!(
                (p - i).abs() > 2 || (q - j).abs() > 2,
                "S at {i},{j} and {p},{q}"
            );
        }
    }
}

#[test]
fn monochromats_and_dichromats_have_the_stated_classes() {
    let (lms, lf) = fractions("LMS");
    for (text, only) in [("L", "L"), ("M", "M"), ("S", "S")] {
        let (m, f) = fractions(text);
        assert_eq!(m.classes.len(), 1);
        assert_eq!(frac(&f, only), 1.0);
    }
    // LS (deuteranope): every M becomes L; S untouched.
    let (m, f) = fractions("LS");
    assert_eq!(
        m.classes
            .iter()
            .map(|c| c.name.as_str())
            .collect::<Vec<_>>(),
        ["L", "S"]
    );
    assert!((frac(&f, "L") - (frac(&lf, "L") + frac(&lf, "M"))).abs() < 1e-12);
    assert_eq!(frac(&f, "S"), frac(&lf, "S"));
    // MS (protanope): every L becomes M.
    let (_, f) = fractions("MS");
    assert!((frac(&f, "M") - (frac(&lf, "L") + frac(&lf, "M"))).abs() < 1e-12);
    // LM (tritanope): each S becomes L or M with ½.
    let (m, f) = fractions("LM");
    assert_eq!(m.classes.len(), 2);
    let s_total = frac(&lf, "S") * (N * N) as f64;
    let to_l = (frac(&f, "L") - frac(&lf, "L")) * (N * N) as f64;
    assert!(
        (to_l / s_total - 0.5).abs() < 0.05,
        "share of S turned L: {}",
        to_l / s_total
    );
    // The base lattice is the same cells: L stays L.
    let l = lms.class_index("L").unwrap();
    let l2 = m.class_index("L").unwrap();
    for cell in 0..N * N {
        if lms.weights[cell * 3 + l] == 1.0 {
            assert_eq!(m.weights[cell * 2 + l2], 1.0);
        }
    }
}

#[test]
fn tetra_turns_half_of_l_into_q() {
    let (_, lf) = fractions("LMS");
    for (text, peak) in [("LMSQ", 545.0), ("LMSQ,Q:506", 506.0)] {
        let (m, f) = fractions(text);
        assert_eq!(m.classes[3].name, "Q");
        assert_eq!(m.classes[3].peak_nm, peak);
        let share = frac(&f, "Q") / frac(&lf, "L");
        assert!((share - 0.5).abs() <= 0.02, "{text}: Q/L_before = {share}");
        assert!((frac(&f, "L") + frac(&f, "Q") - frac(&lf, "L")).abs() < 1e-12);
        assert_eq!(frac(&f, "M"), frac(&lf, "M"));
    }
}

#[test]
fn gene_therapy_affects_the_set_fraction_of_m_cones() {
    let base = Mosaic::from_spec_str("MS", N, SEED).unwrap();
    let m_base = base.class_index("M").unwrap();
    let m_cells: Vec<usize> = (0..N * N)
        .filter(|&c| base.weights[c * 2 + m_base] == 1.0)
        .collect();
    for (text, fraction) in [
        ("MS+L_replace_M", 0.5),
        ("MS+L_coexpress_M", 0.5),
        ("MS+L_ratio_M", 0.5),
        ("MS+L_replace_M@0.6", 0.6),
    ] {
        let m = Mosaic::from_spec_str(text, N, SEED).unwrap();
        assert_eq!(
            m.classes
                .iter()
                .map(|c| c.name.as_str())
                .collect::<Vec<_>>(),
            ["L", "M", "S"]
        );
        let l = m.class_index("L").unwrap();
        let affected = m_cells
            .iter()
            .filter(|&&c| m.weights[c * 3 + l] > 0.0)
            .count();
        let f = affected as f64 / m_cells.len() as f64;
        eprintln!("{text}: affected fraction of M cones {f:.4}");
        assert!((f - fraction).abs() <= 0.02, "{text}: {f}");
        // How affected cones express: replace → pure L, coexpress → 0.5/0.5, ratio → spread.
        let ws: Vec<f32> = m_cells
            .iter()
            .map(|&c| m.weights[c * 3 + l])
            .filter(|&w| w > 0.0)
            .collect();
        if text.contains("replace") {
            assert!(ws.iter().all(|&w| w == 1.0));
        } else if text.contains("coexpress") {
            assert!(ws.iter().all(|&w| (w - 0.5).abs() < 1e-6));
        } else {
            let mean = ws.iter().sum::<f32>() / ws.len() as f32;
            assert!((mean - 0.5).abs() < 0.02, "mean L share {mean}");
            assert!(ws.iter().any(|&w| w < 0.1) && ws.iter().any(|&w| w > 0.9));
        }
        // S cones untouched; every row still sums to 1.
        for row in m.weights.chunks(3) {
            assert!((row.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        }
    }
}

#[test]
fn custom_ratios_and_peaks() {
    let (m, f) = fractions("iid,L=1,M=1,S=1");
    assert_eq!(m.classes.len(), 3);
    for c in ["L", "M", "S"] {
        assert!(
            (frac(&f, c) - 1.0 / 3.0).abs() < 0.01,
            "{c}: {}",
            frac(&f, c)
        );
    }
    let (m, f) = fractions("LMS,lm=1");
    let ratio = frac(&f, "L") / frac(&f, "M");
    assert!((ratio - 1.0).abs() < 0.05, "L/M {ratio}");
    assert_eq!(m.classes[0].peak_nm, 560.0);
    let (m, _) = fractions("L:560,M:550,S:419");
    assert_eq!(m.classes[1].peak_nm, 550.0);
    let (m, f) = fractions("A:450,B:600");
    assert_eq!(m.classes.len(), 2);
    assert!((frac(&f, "A") - 0.5).abs() < 0.01);
    assert_eq!(m.classes[1].peak_nm, 600.0);
}

#[test]
fn same_seed_same_mosaic_other_seed_differs() {
    let a = Mosaic::from_spec_str("LMS", 32, 5).unwrap();
    let b = Mosaic::from_spec_str("LMS", 32, 5).unwrap();
    let c = Mosaic::from_spec_str("LMS", 32, 6).unwrap();
    assert_eq!(a, b);
    assert_ne!(a.weights, c.weights);
}
