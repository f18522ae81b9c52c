//! The foveated layout: spacing ratio, no flips, jitter magnitude.

use super::*;

fn paper(seed: u64) -> ConeLayout {
    ConeLayout::compute(
        &LayoutConfig::Foveated(FoveationConfig::default()),
        256,
        512,
        seed,
    )
}

#[test]
fn paper_layout_centre_to_edge_spacing_ratio_is_official() {
    for seed in 0..3 {
        let l = paper(seed);
        let r = l.centre_to_edge_spacing_ratio();
        eprintln!(
            "paper layout seed {seed}: centre {:.3} px, edge {:.3} px, ratio {r:.3}, \
             required field {} px, {:.5} deg/px",
            l.centre_spacing_px(),
            l.edge_spacing_px(),
            l.required_field_px(),
            l.deg_per_px
        );
        assert!((r - 1.9).abs() <= 0.2, "seed {seed}: ratio {r}");
        // The official rule for the field size gives the official 512 px.
        assert_eq!(l.required_field_px(), 512);
        // Positions span the field.
        for p in &l.positions_px {
            assert!(p[0] >= -1e-3 && p[0] <= 511.001 && p[1] >= -1e-3 && p[1] <= 511.001);
        }
    }
}

#[test]
fn no_lattice_cell_flips_orientation() {
    for seed in 0..4 {
        let l = paper(seed);
        let areas = l.cell_signed_areas_px2();
        let min = areas.iter().copied().fold(f64::INFINITY, f64::min);
        assert!(min > 0.0, "seed {seed}: a cell flipped (signed area {min})");
    }
    // A stronger jitter does flip cells, so the check can fail.
    let wild = FoveationConfig {
        jitter: Some(JitterConfig {
            amplitude_cells: 40.0,
            ..JitterConfig::default()
        }),
        ..FoveationConfig::default()
    };
    let l = ConeLayout::compute(&LayoutConfig::Foveated(wild), 64, 128, 0);
    assert!(l.cell_signed_areas_px2().iter().any(|&a| a <= 0.0));
}

#[test]
fn jitter_std_is_about_half_a_cell() {
    let mut all = vec![];
    for seed in 0..4 {
        let l = paper(seed);
        all.extend(
            l.jitter_cells
                .iter()
                .flat_map(|j| [j[0] as f64, j[1] as f64]),
        );
    }
    let mean = all.iter().sum::<f64>() / all.len() as f64;
    let std = (all.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / all.len() as f64).sqrt();
    let max = all.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    eprintln!("jitter over 4 paper layouts: std {std:.3} cells, max |jitter| {max:.2} cells");
    assert!((std - 0.5).abs() < 0.15, "{std}");
}

#[test]
fn density_falls_from_the_centre() {
    let l = ConeLayout::compute(
        &LayoutConfig::Foveated(FoveationConfig {
            jitter: None,
            ..FoveationConfig::default()
        }),
        64,
        128,
        0,
    );
    let s = l.spacing_px();
    // Along the middle row, spacing grows monotonically from the centre towards the edge (the
    // edge cone itself has one neighbour fewer, so it is left out).
    let row = 32;
    for j in 33..62 {
        assert!(s[row * 64 + j + 1] >= s[row * 64 + j] - 1e-5, "j {j}");
    }
    // Radial symmetry: the four mid-edge cones are equidistant from the centre.
    let c = [63.5f32, 63.5];
    let d = |k: usize| (l.positions_px[k][0] - c[0]).hypot(l.positions_px[k][1] - c[1]);
    let (a, b) = (d(31 * 64), d(31 * 64 + 63));
    assert!((a - b).abs() < 1e-3);
}

#[test]
fn identity_layout_is_the_pixel_grid() {
    let l = ConeLayout::compute(&LayoutConfig::Identity, 8, 8, 0);
    assert_eq!(l.positions_px[8 * 3 + 5], [5.0, 3.0]);
    assert_eq!(l.spacing_px(), vec![1.0; 64]);
    assert!(l
        .cell_signed_areas_px2()
        .iter()
        .all(|&a| (a - 1.0).abs() < 1e-12));
    assert_eq!(l.positions_normalised()[0], [-1.0, -1.0]);
}
