//! Pictures of what the cortex learned, and the learned invariants measured against the truth.
//! Evaluation only: this module reads ground truth (scene colour, cone classes, positions, the
//! DoG kernel); nothing here feeds learning.
//!
//! Files (all PNG unless stated; small lattices are enlarged with nearest-neighbour pixels):
//! - `ons.png` — one held-out ONS frame (grey = 0, white/black = ±max);
//! - `scope.png` — Neural-Scope percept (left) beside the true scene colour at each cone (right),
//!   both sRGB-encoded; the scope is a least-squares N→3 map with bias fitted on held-out scenes;
//! - `learned_c.png` beside `true_mosaic.png` — learned C coloured by the least-squares map from
//!   C to the true class colours (L red, M green, S blue, Q yellow), and the true mosaic;
//! - `w_kernel.png` — learned W kernel (7×7 crop of the inverse FFT, left) beside the true DoG;
//! - `positions.svg` — learned positions P(uv) against the true cone positions.

use crate::config::RunConfig;
use crate::io::{signed_to_rgb, upscale_rgb, write_atomic, write_png_rgb};
use crate::run::RunError;
use crate::source::RetinaSource;
use colorimetry::{srgb, ScopeAccumulator};
use cortex::Trainer;
use retina::Retina;
use serde::{Deserialize, Serialize};
use std::fmt::Write as _;
use std::path::Path;

/// Learned invariants against the truth (paper: "all recovered").
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Invariants {
    /// Adjusted Rand index of k-means clusters of the learned C against the true classes.
    pub c_adjusted_rand_index: Option<f64>,
    /// Correlation of the learned W kernel (7×7) with the true DoG. The initial W (identity, a
    /// delta kernel) already correlates highly with a centre-dominated DoG, so read it together
    /// with [`Invariants::w_surround_correlation`].
    pub w_kernel_correlation: Option<f64>,
    /// The same correlation over the 48 surround taps only (centre excluded): 0 (undefined) for
    /// the initial identity W, near 1 when the inhibitory surround's shape was learned.
    pub w_surround_correlation: Option<f64>,
    /// Correlation of learned and true cone-spacing maps.
    pub p_spacing_correlation: f64,
    /// RMSE of the Neural Scope on held-out scenes (linear sRGB).
    pub scope_rmse: f64,
    /// Hue axis (CIELAB a*b*) of the Neural-Scope colours of the held-out pixels (paper Fig. 5.2:
    /// one axis for a dichromat).
    pub scope_hue_axis: Option<colorimetry::HueAxis>,
    /// The same for the true colours of those pixels (the scenes' own spread, for comparison).
    pub truth_hue_axis: Option<colorimetry::HueAxis>,
}

const CLASS_RGB: [[f64; 3]; 4] = [
    [1.0, 0.2, 0.2],
    [0.2, 0.85, 0.2],
    [0.25, 0.35, 1.0],
    [1.0, 0.9, 0.1],
];

fn enlarge(n: usize) -> usize {
    (256 / n).max(1)
}

fn save_rgb(path: &Path, n: usize, rgb: &[f32]) -> Result<(), RunError> {
    let f = enlarge(n);
    Ok(write_png_rgb(
        path,
        n * f,
        n * f,
        &upscale_rgb(n, n, rgb, f),
    )?)
}

/// Pearson correlation.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    colorimetry::stiles_burch::correlation(a, b)
}

/// Writes every picture into `dir` and returns the measured invariants.
pub fn write_all(
    dir: &Path,
    config: &RunConfig,
    retina: &Retina,
    source: &mut RetinaSource,
    trainer: &Trainer,
) -> Result<Invariants, RunError> {
    std::fs::create_dir_all(dir).map_err(|source| crate::io::IoError::Fs {
        path: dir.to_path_buf(),
        source,
    })?;
    let n = retina.n();
    let nn = n * n;
    let cortex = &trainer.cortex;
    let dim = cortex.percept_dim();
    // Held-out scenes for the Neural Scope: fit on a few batches, show the last sample.
    let mut acc = ScopeAccumulator::new(dim);
    let border = config.cortex.loss.border_px;
    let (mut last_percept, mut last_truth, mut last_ons) = (Vec::new(), Vec::new(), Vec::new());
    let mut rows: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    for _ in 0..4 {
        let b = source.next_eye_batch(4).clone();
        let frames: Vec<f32> = (0..b.batch).flat_map(|s| b.frame(s, 0).to_vec()).collect();
        let percept = cortex.decode_frames(&frames, b.batch);
        let truth = source.retina.srgb_at_cones(&b, 0);
        let (mut p, mut t) = (Vec::new(), Vec::new());
        for s in 0..b.batch {
            for y in border..n - border {
                for x in border..n - border {
                    let i = y * n + x;
                    p.extend((0..dim).map(|d| percept[(s * dim + d) * nn + i] as f64));
                    t.extend((0..3).map(|c| truth[(s * 3 + c) * nn + i] as f64));
                }
            }
        }
        acc.add_batch(&p, &t);
        rows.0.extend_from_slice(&p);
        rows.1.extend_from_slice(&t);
        let s = b.batch - 1;
        last_percept = percept[s * dim * nn..(s + 1) * dim * nn].to_vec();
        last_truth = truth[s * 3 * nn..(s + 1) * 3 * nn].to_vec();
        last_ons = b.frame(s, 0).to_vec();
    }
    let scope = acc.finish()?;
    let scope_rmse = scope.rmse(&rows.0, &rows.1);
    let mut scope_rgb = vec![0.0; rows.1.len()];
    scope.apply_batch(&rows.0, &mut scope_rgb);
    let scope_hue_axis = colorimetry::hue_axis(&scope_rgb);
    let truth_hue_axis = colorimetry::hue_axis(&rows.1);
    save_rgb(&dir.join("ons.png"), n, &signed_to_rgb(&last_ons))?;
    // Scope percept beside the truth, normalised by the truth's brightest channel.
    let peak = last_truth.iter().fold(1e-6f32, |m, &v| m.max(v)) as f64;
    let (mut left, mut right) = (vec![0f32; nn * 3], vec![0f32; nn * 3]);
    let mut v = vec![0.0; dim];
    for i in 0..nn {
        for (d, slot) in v.iter_mut().enumerate() {
            *slot = last_percept[d * nn + i] as f64;
        }
        let rgb = scope.apply(&v);
        for c in 0..3 {
            left[i * 3 + c] = srgb::oetf((rgb[c] / peak).clamp(0.0, 1.0)) as f32;
            right[i * 3 + c] =
                srgb::oetf((last_truth[c * nn + i] as f64 / peak).clamp(0.0, 1.0)) as f32;
        }
    }
    let mut both = Vec::with_capacity(nn * 6);
    for y in 0..n {
        both.extend_from_slice(&left[y * n * 3..(y + 1) * n * 3]);
        both.extend_from_slice(&right[y * n * 3..(y + 1) * n * 3]);
    }
    let f = enlarge(n);
    write_png_rgb(
        &dir.join("scope.png"),
        2 * n * f,
        n * f,
        &upscale_rgb(2 * n, n, &both, f),
    )?;

    // True mosaic and learned C.
    let dominant = retina.mosaic.dominant_class();
    let true_rgb: Vec<f32> = dominant
        .iter()
        .flat_map(|&c| CLASS_RGB[c.min(3)].map(|v| v as f32))
        .collect();
    save_rgb(&dir.join("true_mosaic.png"), n, &true_rgb)?;
    let c_ari = cortex.learned_c().map(|c| {
        let c = c.data().to_vec(); // (n, n, N)
        let targets: Vec<f64> = dominant.iter().flat_map(|&k| CLASS_RGB[k.min(3)]).collect();
        let map = colorimetry::NeuralScope::fit(&c, &targets, dim);
        let rgb: Vec<f32> = match &map {
            Ok(m) => (0..nn)
                .flat_map(|i| {
                    m.apply(&c[i * dim..(i + 1) * dim])
                        .map(|v| v.clamp(0.0, 1.0) as f32)
                })
                .collect(),
            Err(_) => vec![0.5; nn * 3],
        };
        let _ = save_rgb(&dir.join("learned_c.png"), n, &rgb);
        adjusted_rand_index(&kmeans(&c, dim, retina.mosaic.n_classes(), 30), &dominant)
    });

    // W kernel beside the DoG.
    let mut w_surround = None;
    let w_corr = match (cortex.learned_w_kernel(7), retina.dog_kernel()) {
        (Some(learned), Some((dog, 7))) => {
            let l = learned.data().to_vec();
            let mut both = Vec::with_capacity(7 * 14);
            for y in 0..7 {
                both.extend_from_slice(&l[y * 7..(y + 1) * 7]);
                both.extend_from_slice(&dog[y * 7..(y + 1) * 7]);
            }
            let rgb = signed_to_rgb(&both.iter().map(|&v| v as f32).collect::<Vec<_>>());
            write_png_rgb(
                &dir.join("w_kernel.png"),
                14 * 16,
                7 * 16,
                &upscale_rgb(14, 7, &rgb, 16),
            )?;
            let ring = |k: &[f64]| -> Vec<f64> {
                k.iter()
                    .enumerate()
                    .filter(|&(i, _)| i != 24)
                    .map(|(_, &v)| v)
                    .collect()
            };
            // A surround at rounding level (the identity W) has no shape to correlate.
            let (lr, centre) = (ring(&l), l[24].abs());
            let flat = lr.iter().all(|v| v.abs() <= 1e-6 * centre);
            let r = correlation(&lr, &ring(dog));
            w_surround = Some(if r.is_finite() && !flat { r } else { 0.0 });
            Some(correlation(&l, dog))
        }
        _ => None,
    };

    // Positions: learned P(uv) vs the true positions (both normalised to [−1, 1]).
    let learned = cortex.learned_positions();
    let learned = learned.data();
    let truth = retina.layout.positions_normalised();
    let mut svg = String::from("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"840\" height=\"420\" viewBox=\"0 0 840 420\">\n<rect width=\"840\" height=\"420\" fill=\"white\"/>\n<text x=\"10\" y=\"16\" font-size=\"13\">learned positions P(uv) (left) and true cone positions (right)</text>\n");
    let step = (n / 32).max(1);
    for (panel, pts) in [
        (
            0.0,
            (0..nn)
                .map(|i| [learned[2 * i], learned[2 * i + 1]])
                .collect::<Vec<_>>(),
        ),
        (
            420.0,
            truth.iter().map(|p| [p[0] as f64, p[1] as f64]).collect(),
        ),
    ] {
        for y in (0..n).step_by(step) {
            for x in (0..n).step_by(step) {
                let p = pts[y * n + x];
                let _ = writeln!(
                    svg,
                    "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"1.6\" fill=\"#333\"/>",
                    panel + 210.0 + 190.0 * p[0],
                    220.0 + 190.0 * p[1]
                );
            }
        }
    }
    svg.push_str("</svg>\n");
    write_atomic(&dir.join("positions.svg"), svg.as_bytes())?;
    let spacing = |pts: &dyn Fn(usize) -> [f64; 2]| -> Vec<f64> {
        let mut s = Vec::with_capacity(nn);
        for y in 0..n {
            for x in 0..n {
                let neighbour = if x + 1 < n { x + 1 } else { x - 1 };
                let (a, b) = (pts(y * n + x), pts(y * n + neighbour));
                s.push(((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt());
            }
        }
        s
    };
    let ls = spacing(&|i| [learned[2 * i], learned[2 * i + 1]]);
    let ts = spacing(&|i| [truth[i][0] as f64, truth[i][1] as f64]);
    let p_corr = correlation(&ls, &ts);
    Ok(Invariants {
        c_adjusted_rand_index: c_ari,
        w_kernel_correlation: w_corr,
        w_surround_correlation: w_surround,
        p_spacing_correlation: if p_corr.is_finite() { p_corr } else { 0.0 },
        scope_rmse,
        scope_hue_axis,
        truth_hue_axis,
    })
}

/// Deterministic k-means (k-means++-like farthest-point init from point 0) on `(m, dim)` rows.
pub fn kmeans(x: &[f64], dim: usize, k: usize, iterations: usize) -> Vec<usize> {
    let m = x.len() / dim;
    let row = |i: usize| &x[i * dim..(i + 1) * dim];
    let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum::<f64>();
    let mut centres: Vec<Vec<f64>> = vec![row(0).to_vec()];
    while centres.len() < k.min(m) {
        let far = (0..m)
            .max_by(|&a, &b| {
                let da = centres
                    .iter()
                    .map(|c| d2(row(a), c))
                    .fold(f64::INFINITY, f64::min);
                let db = centres
                    .iter()
                    .map(|c| d2(row(b), c))
                    .fold(f64::INFINITY, f64::min);
                da.total_cmp(&db)
            })
            .expect("rows exist");
        centres.push(row(far).to_vec());
    }
    let mut labels = vec![0; m];
    for _ in 0..iterations {
        for (i, l) in labels.iter_mut().enumerate() {
            *l = (0..centres.len())
                .min_by(|&a, &b| d2(row(i), &centres[a]).total_cmp(&d2(row(i), &centres[b])))
                .unwrap_or(0);
        }
        for (c, centre) in centres.iter_mut().enumerate() {
            let members: Vec<usize> = (0..m).filter(|&i| labels[i] == c).collect();
            if !members.is_empty() {
                for (d, v) in centre.iter_mut().enumerate() {
                    *v = members.iter().map(|&i| row(i)[d]).sum::<f64>() / members.len() as f64;
                }
            }
        }
    }
    labels
}

/// Adjusted Rand index of two labelings (Hubert & Arabie 1985): 1 = identical partitions,
/// ≈ 0 = chance.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "adjusted_rand_index: {} vs {} labels",
        a.len(),
        b.len()
    );
    let (ka, kb) = (
        a.iter().max().map_or(0, |m| m + 1),
        b.iter().max().map_or(0, |m| m + 1),
    );
    let mut table = vec![0f64; ka * kb];
    for (&i, &j) in a.iter().zip(b) {
        table[i * kb + j] += 1.0;
    }
    let c2 = |x: f64| x * (x - 1.0) / 2.0;
    let sum_ij: f64 = table.iter().map(|&v| c2(v)).sum();
    let sum_a: f64 = (0..ka)
        .map(|i| c2((0..kb).map(|j| table[i * kb + j]).sum()))
        .sum();
    let sum_b: f64 = (0..kb)
        .map(|j| c2((0..ka).map(|i| table[i * kb + j]).sum()))
        .sum();
    let total = c2(a.len() as f64);
    let expected = sum_a * sum_b / total.max(1.0);
    let max = 0.5 * (sum_a + sum_b);
    if (max - expected).abs() < 1e-12 {
        return 1.0;
    }
    (sum_ij - expected) / (max - expected)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn adjusted_rand_index_is_one_for_relabelled_partitions_and_near_zero_for_unrelated() {
        let a = [0, 0, 1, 1, 2, 2];
        assert!((adjusted_rand_index(&a, &[2, 2, 0, 0, 1, 1]) - 1.0).abs() < 1e-12);
        let b = [0, 1, 0, 1, 0, 1];
        assert!(adjusted_rand_index(&a, &b) < 0.1);
    }

    #[test]
    fn kmeans_separates_well_separated_clusters() {
        let x = [0.0, 0.1, 0.05, 5.0, 5.1, 4.9];
        let l = kmeans(&x, 1, 2, 10);
        assert_eq!(adjusted_rand_index(&l, &[0, 0, 0, 1, 1, 1]), 1.0);
    }
}
