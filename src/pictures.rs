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
//! - `positions.svg` — learned positions P(uv) against the true cone positions;
//! - `own_<class>.png` — the eye's last class's own signal (what the other classes do not
//!   predict: S for a trichromat, Q for a tetrachromat, the dimension Neural Scope's three
//!   channels cannot show), the scene's colour (left), the truth's own image (middle) and the
//!   percept's reading of it (right), signed grey on the truth's scale; its held-out R² is
//!   `own_image` in `summary.json` ([`science::invariants::own_image`]).

use crate::io::{signed_to_rgb, upscale_rgb, write_atomic, write_png_rgb};
use crate::run::error::RunError;
use colorimetry::{srgb, ScopeAccumulator};
use cortex::{Cortex, Trainer};
use retina::Retina;
use science::config::RunConfig;
use science::invariants::own_image::{self, OwnImagePicture};
use science::source::RetinaSource;
use science::summary::{Invariants, OwnImageFigure, HUE_ERROR_MIN_CHROMA};
use std::fmt::Write as _;
use std::path::Path;

/// The smallest full scale of `own_<class>.png`, as a fraction of the class's excitation range
/// in the scene shown (a display setting, not a physical constant: an own signal smaller than 1 %
/// of the class's range is drawn at that fraction of full contrast, not stretched to it).
const OWN_IMAGE_FLOOR: f64 = 0.01;

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

/// Writes every picture into `dir` and returns the measured invariants. With `held_out` the
/// hidden-signal figures and the own image are measured too, on
/// `config.schedule.held_out_scenes` held-out scenes each (a run's end and `scope`; the
/// pictures during training leave them out, their figures were never kept).
pub fn write_all(
    dir: &Path,
    config: &RunConfig,
    retina: &Retina,
    source: &mut RetinaSource,
    trainer: &Trainer,
    held_out: bool,
) -> Result<Invariants, RunError> {
    std::fs::create_dir_all(dir).map_err(|source| crate::io::IoError::Fs {
        path: dir.to_path_buf(),
        source,
    })?;
    let cortex = &trainer.cortex;
    let scope = write_scope(dir, config, source, cortex)?;
    write_learned_c(dir, retina, cortex)?;
    write_w_kernel(dir, retina, cortex)?;
    write_positions(dir, retina, cortex)?;
    // What the eye hides on the run's fixed held-out scenes (a fresh held-out stream, as
    // `convergence` measures every checkpoint), not on wherever `source` has got to.
    let (recovery, own_image) = if held_out {
        let count = config.schedule.held_out_scenes;
        let mut scenes = science::heldout::hidden_source(config)?;
        let recovery = science::invariants::measure_with_scenes(cortex, &mut scenes, count);
        // The last class's own signal on the next held-out scenes of the same stream.
        let own = own_image::held_out(cortex, &mut scenes, count);
        (
            recovery,
            own.map(|own| write_own_image(dir, &own)).transpose()?,
        )
    } else {
        (science::invariants::measure(cortex, retina), None)
    };
    Ok(Invariants {
        recovery,
        scope_rmse: scope.rmse,
        scope_hue_axis: scope.hue_axis,
        truth_hue_axis: scope.truth_hue_axis,
        ideal_hue_axis: scope.ideal_hue_axis,
        scope_hue_error: scope.hue_error,
        own_image,
    })
}

/// What the Neural Scope measured on held-out scenes.
struct ScopeFit {
    rmse: f64,
    hue_axis: Option<colorimetry::HueAxis>,
    truth_hue_axis: Option<colorimetry::HueAxis>,
    ideal_hue_axis: Option<colorimetry::HueAxis>,
    hue_error: Option<colorimetry::HueError>,
}

/// The pixels of planes `(B, channels, n, n)` inside `border` as rows `(pixels, channels)`,
/// appended to `rows`.
fn pixel_rows(planes: &[f32], channels: usize, n: usize, border: usize, rows: &mut Vec<f64>) {
    let nn = n * n;
    for sample in planes.chunks_exact(channels * nn) {
        for y in border..n - border {
            for x in border..n - border {
                rows.extend((0..channels).map(|c| sample[c * nn + y * n + x] as f64));
            }
        }
    }
}

/// [`colorimetry::hue_axis`] of the least-squares affine map from `inputs` rows to `targets`
/// (linear sRGB rows) applied to `inputs`; `None` when the fit fails.
fn fitted_hue_axis(inputs: &[f64], dim: usize, targets: &[f64]) -> Option<colorimetry::HueAxis> {
    let fit = colorimetry::NeuralScope::fit(inputs, targets, dim).ok()?;
    let mut rgb = vec![0.0; targets.len()];
    fit.apply_batch(inputs, &mut rgb);
    colorimetry::hue_axis(&rgb)
}

/// Neural Scope on held-out scenes (fit on 4 batches of 4, show the last sample): `ons.png` and
/// `scope.png` (the percept through the fitted map beside the true colour, normalised by the
/// truth's brightest channel).
fn write_scope(
    dir: &Path,
    config: &RunConfig,
    source: &mut RetinaSource,
    cortex: &Cortex,
) -> Result<ScopeFit, RunError> {
    let n = source.retina.n();
    let nn = n * n;
    let dim = cortex.percept_dim();
    // Held-out scenes for the Neural Scope: fit on a few batches, show the last sample.
    let mut acc = ScopeAccumulator::new(dim);
    let border = config.cortex.loss.border_px;
    let (mut last_percept, mut last_truth, mut last_ons) = (Vec::new(), Vec::new(), Vec::new());
    let mut rows: (Vec<f64>, Vec<f64>) = (Vec::new(), Vec::new());
    let classes = source.retina.mosaic.n_classes();
    let mut excitations = Vec::new();
    for _ in 0..4 {
        let b = source.next_eye_batch(4).clone();
        let samples = b.signal.batch;
        let mut frames = Vec::new();
        b.signal.frames(0, &mut frames);
        let percept = cortex.decode_frames(&frames, samples);
        let truth = source.retina.srgb_at_cones(&b.truth, 0);
        let (mut p, mut t) = (Vec::new(), Vec::new());
        pixel_rows(&percept, dim, n, border, &mut p);
        pixel_rows(&truth, 3, n, border, &mut t);
        let ex = source.retina.class_excitations_at_cones(&b.truth, 0);
        pixel_rows(&ex, classes, n, border, &mut excitations);
        acc.add_batch(&p, &t);
        rows.0.extend_from_slice(&p);
        rows.1.extend_from_slice(&t);
        let s = samples - 1;
        last_percept = percept[s * dim * nn..(s + 1) * dim * nn].to_vec();
        last_truth = truth[s * 3 * nn..(s + 1) * 3 * nn].to_vec();
        last_ons = b.signal.frame(s, 0).to_vec();
    }
    let scope = acc.finish()?;
    let scope_rmse = scope.rmse(&rows.0, &rows.1);
    let mut scope_rgb = vec![0.0; rows.1.len()];
    scope.apply_batch(&rows.0, &mut scope_rgb);
    let scope_hue_axis = colorimetry::hue_axis(&scope_rgb);
    let truth_hue_axis = colorimetry::hue_axis(&rows.1);
    let ideal_hue_axis = fitted_hue_axis(&excitations, classes, &rows.1);
    let hue_error = colorimetry::hue_error(&scope_rgb, &rows.1, HUE_ERROR_MIN_CHROMA);
    save_rgb(&dir.join("ons.png"), n, &signed_to_rgb(&last_ons))?;
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
    Ok(ScopeFit {
        rmse: scope_rmse,
        hue_axis: scope_hue_axis,
        truth_hue_axis,
        ideal_hue_axis,
        hue_error,
    })
}

/// `own_<class>.png` (module docs): the last held-out scene's colour (normalised by its
/// brightest channel) beside the class's own signal in the truth and as the percept reads it,
/// signed grey on the truth's scale (grey 0, white and black ± its largest magnitude there, or
/// ± [`OWN_IMAGE_FLOOR`] of the class's range when that is larger: an own signal of rounding
/// size stays grey instead of being stretched into noise).
fn write_own_image(dir: &Path, own: &OwnImagePicture) -> Result<OwnImageFigure, RunError> {
    let (n, border) = (own.n, own.border);
    let (nn, side) = (n * n, n - 2 * border);
    let peak = own.scene_srgb.iter().fold(1e-6f32, |m, &v| m.max(v)) as f64;
    let mut scene = vec![0f32; nn * 3];
    for (i, rgb) in scene.chunks_exact_mut(3).enumerate() {
        for (c, v) in rgb.iter_mut().enumerate() {
            *v = srgb::oetf((own.scene_srgb[c * nn + i] as f64 / peak).clamp(0.0, 1.0)) as f32;
        }
    }
    let floor = (OWN_IMAGE_FLOOR * own.class_range).max(1e-12);
    let scale = own.truth.iter().fold(floor, |m, v| m.max(v.abs()));
    let panel = |values: &[f64]| {
        let mut rgb = vec![0.5f32; nn * 3];
        for (i, v) in values.iter().enumerate() {
            let (y, x) = (border + i / side, border + i % side);
            let grey = (0.5 + 0.5 * v / scale).clamp(0.0, 1.0) as f32;
            rgb[(y * n + x) * 3..][..3].fill(grey);
        }
        rgb
    };
    let (truth, reading) = (panel(&own.truth), panel(&own.reading));
    let mut three = Vec::with_capacity(nn * 9);
    for y in 0..n {
        for image in [&scene, &truth, &reading] {
            three.extend_from_slice(&image[y * n * 3..(y + 1) * n * 3]);
        }
    }
    let figure = OwnImageFigure {
        class: own.class.clone(),
        held_out_r2: own.held_out_r2,
    };
    let f = enlarge(n);
    write_png_rgb(
        &dir.join(figure.file_name()),
        3 * n * f,
        n * f,
        &upscale_rgb(3 * n, n, &three, f),
    )?;
    Ok(figure)
}

/// `true_mosaic.png` (dominant class per cone) and, with a learned C, `learned_c.png` (C mapped
/// to the class colours by a Neural-Scope fit).
fn write_learned_c(dir: &Path, retina: &Retina, cortex: &Cortex) -> Result<(), RunError> {
    let n = retina.n();
    let nn = n * n;
    let dim = cortex.percept_dim();
    let dominant = retina.mosaic.dominant_class();
    let true_rgb: Vec<f32> = dominant
        .iter()
        .flat_map(|&c| CLASS_RGB[c.min(3)].map(|v| v as f32))
        .collect();
    save_rgb(&dir.join("true_mosaic.png"), n, &true_rgb)?;
    if let Some(c) = cortex.learned_c() {
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
        save_rgb(&dir.join("learned_c.png"), n, &rgb)?;
    }
    Ok(())
}

/// `w_kernel.png`: the learned 7×7 W kernel beside the eye's DoG (when both exist).
fn write_w_kernel(dir: &Path, retina: &Retina, cortex: &Cortex) -> Result<(), RunError> {
    if let (Some(learned), Some((dog, 7))) = (cortex.learned_w_kernel(7), retina.dog_kernel()) {
        let l = learned.data();
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
    }
    Ok(())
}

/// `positions.svg`: learned P(uv) (left) against the true positions (right), both in [−1, 1]
/// (a panel whose points reach beyond is scaled down to hold them all).
fn write_positions(dir: &Path, retina: &Retina, cortex: &Cortex) -> Result<(), RunError> {
    let n = retina.n();
    let nn = n * n;
    let learned = cortex.learned_positions();
    let learned = learned.data();
    let truth = retina.layout.positions_normalised();
    let mut svg = String::from("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"840\" height=\"420\" viewBox=\"0 0 840 420\" font-family=\"sans-serif\">\n<rect width=\"840\" height=\"420\" fill=\"white\"/>\n<text x=\"10\" y=\"16\" font-size=\"13\">learned positions P(uv) (left) and true cone positions (right)</text>\n");
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
        // [−1, 1] fills the panel; learned positions beyond it shrink the panel's scale.
        let reach = pts
            .iter()
            .flatten()
            .map(|v| v.abs())
            .filter(|v| v.is_finite())
            .fold(1.0, f64::max);
        let scale = 190.0 / reach;
        for y in (0..n).step_by(step) {
            for x in (0..n).step_by(step) {
                let p = pts[y * n + x];
                let _ = writeln!(
                    svg,
                    "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"1.6\" fill=\"#333\"/>",
                    panel + 210.0 + scale * p[0],
                    220.0 + scale * p[1]
                );
            }
        }
    }
    svg.push_str("</svg>\n");
    write_atomic(&dir.join("positions.svg"), svg.as_bytes())?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The ideal observer's hue axis for the `tiny` eye with `cones`, on 4 batches of 4 scenes.
    fn ideal_axis(cones: &str) -> colorimetry::HueAxis {
        let config = RunConfig::preset("tiny", cones).unwrap();
        let retina = Retina::new(config.retina.clone()).unwrap();
        let classes = retina.mosaic.n_classes();
        let n = retina.n();
        let mut source = RetinaSource::new(retina, 7, true);
        let (mut excitations, mut truth) = (Vec::new(), Vec::new());
        for _ in 0..4 {
            let b = source.next_eye_batch(4).clone();
            let ex = source.retina.class_excitations_at_cones(&b.truth, 0);
            pixel_rows(&ex, classes, n, 3, &mut excitations);
            let rgb = source.retina.srgb_at_cones(&b.truth, 0);
            pixel_rows(&rgb, 3, n, 3, &mut truth);
        }
        fitted_hue_axis(&excitations, classes, &truth).unwrap()
    }

    #[test]
    fn an_ideal_dichromat_sees_blue_yellow_without_l_or_m_and_teal_red_without_s() {
        // Paper Fig. 5.2. Yellow–blue lies near b* (90°); the tritan confusion colours, red and
        // teal (≈ 40° and ≈ 230° in a*b*), lie on an axis well away from it.
        for cones in ["LS", "MS"] {
            let a = ideal_axis(cones);
            assert!((85.0..125.0).contains(&a.angle_deg), "{cones}: {a:?}");
            assert!(a.minor_to_major < 0.25, "{cones}: {a:?}");
        }
        let lm = ideal_axis("LM");
        assert!((30.0..80.0).contains(&lm.angle_deg), "LM: {lm:?}");
        assert!(lm.minor_to_major < 0.3, "LM: {lm:?}");
        // A trichromat has no single axis: its colours spread as the scenes' do.
        let lms = ideal_axis("LMS");
        assert!(lms.minor_to_major > 0.35, "LMS: {lms:?}");
    }
}
