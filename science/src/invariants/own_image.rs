//! A cone class's own signal as a picture: what class k catches beyond the other classes at each
//! cone, beside the percept's reading of it (the newest colour dimension made visible: S for a
//! trichromat, the fourth class Q for a tetrachromat). Evaluation only: this reads the true
//! excitations of held-out scenes; nothing here feeds learning.
//!
//! Neural Scope maps the percept to three sRGB channels, so a fourth dimension cannot show in it.
//! This measure shows it apart:
//! 1. the **truth's own image** of class k: at every site, `u_k = e_k − (affine least-squares
//!    prediction of e_k from the other classes' true excitations at the same place)`, one fit over
//!    every site given (as [`super::hidden`] defines the unique part, but at every cone, not only
//!    at the hidden ones, so that it makes a whole picture);
//! 2. the **percept's reading**: an affine least-squares map from the `N`-dimensional percept to
//!    `u_k`, fitted on the first `fit_sites` sites and applied to every site;
//! 3. its **held-out R²** on the sites after `fit_sites` (1: the percept carries class k's own
//!    signal; 0 or below: it carries only what the other classes already tell).
//!
//! At a cone of class k itself the eye measures `e_k`, so there a percept can read `u_k` without
//! having filled anything in; [`super::hidden`]'s `unique_r2` scores the hidden sites alone and is
//! the figure that says whether the cortex demosaicked class k. This R² is the picture's own.
//!
//! Layout: `percept` row-major `(sites, dim)`, `excitation` row-major `(sites, classes)`.

use super::hidden::{affine_residuals, held_out_r2};
use super::{gather_cortex_held_out, HeldOutScenes};
use crate::source::RetinaSource;
use cortex::Cortex;

/// Class k's own signal at every site and the percept's reading of it (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnImage {
    /// `u_k` at every site, in excitation units.
    pub truth: Vec<f64>,
    /// The percept's affine reading of `u_k` at every site (fitted on the first `fit_sites`).
    pub reading: Vec<f64>,
    /// Held-out R² of the reading on the sites after `fit_sites`.
    pub held_out_r2: f64,
}

/// Class `k`'s own signal and the percept's reading of it over `excitation.len() / classes`
/// sites, the reading fitted on the first `fit_sites` (module docs).
pub fn own_image(
    percept: &[f64],
    excitation: &[f64],
    dim: usize,
    classes: usize,
    k: usize,
    fit_sites: usize,
) -> OwnImage {
    own_image_at(
        (percept, excitation),
        fit_sites,
        (percept, excitation),
        dim,
        classes,
        k,
    )
}

/// [`own_image`] fitted and scored on `rows = (percept, excitation)` (the first `fit_sites` sites
/// fit, the rest score), with its truth and reading given at the sites of `shown`, which need not
/// be among `rows` (a whole scene beside a sample of sites from many scenes).
pub fn own_image_at(
    rows: (&[f64], &[f64]),
    fit_sites: usize,
    shown: (&[f64], &[f64]),
    dim: usize,
    classes: usize,
    k: usize,
) -> OwnImage {
    let ((percept, excitation), sites) = (rows, rows.1.len() / classes.max(1));
    assert!(
        classes >= 2 && k < classes && excitation.len() == sites * classes,
        "own_image: class {k} of {classes}, {} excitations",
        excitation.len()
    );
    assert!(
        percept.len() == sites * dim && fit_sites > 0 && fit_sites < sites,
        "own_image: {} percept values for {sites} sites of {dim} channels, fit on {fit_sites}",
        percept.len()
    );
    assert!(
        shown.0.len() * classes == shown.1.len() * dim,
        "own_image: {} shown percept values against {} excitations",
        shown.0.len(),
        shown.1.len()
    );
    // One fit of class k on the others over the rows, applied to the rows and the shown sites.
    let (others, target) = split_class(excitation, classes, k);
    let (shown_others, shown_target) = split_class(shown.1, classes, k);
    let mut residuals = affine_residuals(
        (&others, &target),
        (
            &[&others[..], &shown_others[..]].concat(),
            &[&target[..], &shown_target[..]].concat(),
        ),
        classes - 1,
    );
    let truth = residuals.split_off(sites);
    let unique = residuals;
    let fit = (&percept[..fit_sites * dim], &unique[..fit_sites]);
    let left = affine_residuals(fit, (shown.0, &truth), dim);
    let reading = truth.iter().zip(&left).map(|(u, r)| u - r).collect();
    let held_out_r2 = held_out_r2(
        fit,
        (&percept[fit_sites * dim..], &unique[fit_sites..]),
        dim,
    );
    OwnImage {
        truth,
        reading,
        held_out_r2,
    }
}

/// Row-major `(sites, classes)` excitations split into the other classes' `(sites, classes − 1)`
/// and class `k`'s `(sites)`.
fn split_class(excitation: &[f64], classes: usize, k: usize) -> (Vec<f64>, Vec<f64>) {
    let target = excitation.chunks_exact(classes).map(|e| e[k]).collect();
    let others = excitation
        .chunks_exact(classes)
        .flat_map(|e| {
            e.iter()
                .enumerate()
                .filter(|&(j, _)| j != k)
                .map(|(_, &v)| v)
        })
        .collect();
    (others, target)
}

/// The last class's own signal on held-out scenes, with what its picture shows ([`held_out`]).
#[derive(Clone, Debug, PartialEq)]
pub struct OwnImagePicture {
    /// The class (the eye's last: S for LMS, Q for LMSQ).
    pub class: String,
    /// Held-out R² of the percept's reading over the sites of the scoring half of the scenes
    /// (the cones inside the border that [`super::hidden::HiddenSamples::add`] keeps: every
    /// [`super::hidden::site_stride`]-th, at most 16 × 16 a scene).
    pub held_out_r2: f64,
    /// Cones per side.
    pub n: usize,
    /// The loss border: the own images cover the `side = n − 2·border` cones inside it.
    pub border: usize,
    /// The last scene's linear sRGB at each cone, `(3, n, n)`.
    pub scene_srgb: Vec<f32>,
    /// The last scene's own signal inside the border, row-major `(side, side)`.
    pub truth: Vec<f64>,
    /// The percept's reading of it, row-major `(side, side)`.
    pub reading: Vec<f64>,
    /// The range (largest − smallest) of the class's excitation over the last scene's sites:
    /// the scale against which its own signal is small or not.
    pub class_range: f64,
}

/// [`own_image`] of the eye's last class on the next `scenes` held-out scenes of `source`
/// (frame 0, batches of [`super::HIDDEN_BATCH_SIZE`], the count rounded up to whole batches,
/// drawn and read one batch at a time: [`super::gather_held_out`]), at the cones inside the
/// loss border that [`super::hidden::HiddenSamples::add`] keeps: the first half of the scenes
/// fits the reading, the second half scores it, and the picture is the last scene's, at every
/// cone inside the border. `None` for a one-class eye (before any scene is drawn) or fewer
/// than two scenes.
pub fn held_out(
    cortex: &Cortex,
    source: &mut RetinaSource,
    scenes: usize,
) -> Option<OwnImagePicture> {
    if source.retina.mosaic.n_classes() < 2 {
        return None;
    }
    let gathered = gather_cortex_held_out(cortex, source, scenes);
    of_scenes(&source.retina, &gathered, cortex.config.loss.border_px)
}

/// [`held_out`] of scenes already gathered (by [`super::gather_held_out`], from any decoder)
/// on `retina`, read at the cones inside `border`. `None` for a one-class eye or fewer than
/// two samples.
pub fn of_scenes(
    retina: &retina::Retina,
    scenes: &HeldOutScenes,
    border: usize,
) -> Option<OwnImagePicture> {
    let (n, classes) = (retina.n(), retina.mosaic.n_classes());
    let (samples, last) = (&scenes.samples, scenes.last.as_ref()?);
    if classes < 2 || samples.len() < 2 {
        return None;
    }
    let dim = samples.dim();
    let (count, per_sample) = (samples.len(), samples.sites_per_sample());
    let (percept, excitation) = samples.all_sites(0..count);
    // The picture: every cone inside the border of the last scene.
    let (nn, inside) = (n * n, border..n - border);
    let (mut shown_percept, mut shown_excitation) = (Vec::new(), Vec::new());
    for i in inside
        .clone()
        .flat_map(|y| inside.clone().map(move |x| y * n + x))
    {
        shown_percept.extend((0..dim).map(|d| last.percept[d * nn + i] as f64));
        shown_excitation.extend((0..classes).map(|c| last.excitation[c * nn + i] as f64));
    }
    let shown = (&shown_percept[..], &shown_excitation[..]);
    let own = own_image_at(
        (&percept, &excitation),
        count / 2 * per_sample,
        shown,
        dim,
        classes,
        classes - 1,
    );
    let last_class = shown_excitation.iter().skip(classes - 1).step_by(classes);
    let (low, high) = last_class.fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
        (l.min(v), h.max(v))
    });
    Some(OwnImagePicture {
        class: retina.mosaic.classes[classes - 1].name.clone(),
        held_out_r2: own.held_out_r2,
        n,
        border,
        scene_srgb: last.srgb.clone(),
        truth: own.truth,
        reading: own.reading,
        class_range: high - low,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four classes at `sites` sites: L, M, S share a luminance, Q = a mix of them plus an own
    /// signal `q_own`; returns the excitations and the own signal.
    fn tetrachromat(sites: usize) -> (Vec<f64>, Vec<f64>) {
        let mut state = 12345u64;
        let mut draw = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let (mut excitation, mut own) = (Vec::new(), Vec::new());
        for _ in 0..sites {
            let (lum, rg, by, q_own) = (1.0 + draw(), draw(), draw(), 0.3 * draw());
            let (l, m, s) = (lum + rg, lum - rg, lum + by);
            excitation.extend([l, m, s, 0.5 * l + 0.3 * m + 0.2 * s + q_own]);
            own.push(q_own);
        }
        (excitation, own)
    }

    fn percept_of(excitation: &[f64], carries_q: bool) -> Vec<f64> {
        excitation
            .chunks_exact(4)
            .flat_map(|e| {
                let q = if carries_q { e[3] } else { 0.2 * e[0] };
                [e[0] + e[1], e[0] - e[1], e[2] - 0.5 * e[0], q]
            })
            .collect()
    }

    fn correlation(a: &[f64], b: &[f64]) -> f64 {
        let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
        let (ma, mb) = (mean(a), mean(b));
        let dot = |f: &dyn Fn(usize) -> f64| (0..a.len()).map(f).sum::<f64>();
        let ab = dot(&|i| (a[i] - ma) * (b[i] - mb));
        ab / (dot(&|i| (a[i] - ma).powi(2)) * dot(&|i| (b[i] - mb).powi(2))).sqrt()
    }

    #[test]
    fn a_percept_that_carries_the_fourth_class_reads_its_own_signal() {
        let (excitation, own) = tetrachromat(4000);
        let percept = percept_of(&excitation, true);
        let s = own_image(&percept, &excitation, 4, 4, 3, 2000);
        assert!(s.held_out_r2 > 0.999, "R² {}", s.held_out_r2);
        let r = correlation(&s.truth, &own);
        assert!(
            r > 0.99,
            "the truth's own image against the own signal drawn: r = {r}"
        );
        for c in 0..3 {
            let column: Vec<f64> = excitation.iter().skip(c).step_by(4).copied().collect();
            let r = correlation(&s.truth, &column);
            assert!(
                r.abs() < 1e-9,
                "own image correlates with class {c}: r = {r}"
            );
        }
        for (i, (u, r)) in s.truth.iter().zip(&s.reading).enumerate() {
            assert!((u - r).abs() < 1e-9, "site {i}: truth {u}, reading {r}");
        }
    }

    #[test]
    fn a_percept_of_l_m_s_alone_reads_nothing_of_the_fourth() {
        let (excitation, _) = tetrachromat(4000);
        let percept = percept_of(&excitation, false);
        let s = own_image(&percept, &excitation, 4, 4, 3, 2000);
        assert!(s.held_out_r2 < 0.02, "R² {}", s.held_out_r2);
        let size = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        assert!(
            size(&s.reading) < 0.1 * size(&s.truth),
            "reading {} against truth {}",
            size(&s.reading),
            size(&s.truth)
        );
    }

    /// Shown at some of the rows' own sites, the truth and the reading are the measure's values
    /// there; shown at sites outside the rows (a whole scene beside a sample of sites), they are
    /// the rows' fits applied there: the own signal drawn, read exactly by a percept that
    /// carries it.
    #[test]
    fn shown_sites_read_as_the_fits_of_the_rows() {
        let (excitation, own) = tetrachromat(4000);
        let percept = percept_of(&excitation, true);
        let rows = (&percept[..3000 * 4], &excitation[..3000 * 4]);
        let whole = own_image(rows.0, rows.1, 4, 4, 3, 1500);
        let inside = own_image_at(
            rows,
            1500,
            (
                &percept[2000 * 4..3000 * 4],
                &excitation[2000 * 4..3000 * 4],
            ),
            4,
            4,
            3,
        );
        assert_eq!(inside.held_out_r2, whole.held_out_r2);
        assert_eq!(inside.truth, whole.truth[2000..3000]);
        assert_eq!(inside.reading, whole.reading[2000..3000]);
        let outside = own_image_at(
            rows,
            1500,
            (&percept[3000 * 4..], &excitation[3000 * 4..]),
            4,
            4,
            3,
        );
        assert_eq!(outside.truth.len(), 1000);
        let r = correlation(&outside.truth, &own[3000..]);
        assert!(
            r > 0.99,
            "outside the rows, truth against the own signal: r = {r}"
        );
        for (i, (u, r)) in outside.truth.iter().zip(&outside.reading).enumerate() {
            assert!((u - r).abs() < 1e-9, "site {i}: truth {u}, reading {r}");
        }
    }
    /// An eye of one class has no own signal to show: `None`, without a single decode or scene.
    #[test]
    fn a_one_class_eye_answers_none_before_decoding() {
        let config = crate::config::RunConfig::preset("tiny", "L").unwrap();
        let cortex = Cortex::new(config.cortex.clone()).unwrap();
        let mut source = crate::heldout::hidden_source(&config).unwrap();
        assert!(held_out(&cortex, &mut source, 8).is_none());
        assert_eq!(source.batches_drawn(), 0, "a one-class eye drew scenes");
    }
}
