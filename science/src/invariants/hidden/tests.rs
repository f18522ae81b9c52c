//! Tests of what the eye hides: the held-out R² of each class's own signal on built cases.

use super::*;
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// Cones per side of the synthetic scenes.
pub(in crate::invariants) const N: usize = 24;

/// A smooth 3-class scene: a shared luminance field and independent chromatic fields, so
/// each class has a unique part; classes on a random mosaic (S one cone in ten).
fn scene(rng: &mut SmallRng) -> (Vec<f32>, Vec<usize>) {
    let mut ex = vec![0f32; 3 * N * N];
    let (fx, fy) = (rng.random_range(0.1..0.4), rng.random_range(0.1..0.4));
    let ph: [f64; 4] = std::array::from_fn(|_| rng.random_range(0.0..std::f64::consts::TAU));
    for y in 0..N {
        for x in 0..N {
            let (xf, yf) = (x as f64, y as f64);
            let lum = 1.0 + 0.5 * (fx * xf + ph[0]).sin();
            let rg = 0.2 * (fy * yf + ph[1]).sin();
            let by = 0.3 * (fx * yf + fy * xf + ph[2]).cos();
            let i = y * N + x;
            ex[i] = (lum + rg) as f32;
            ex[N * N + i] = (0.9 * lum - rg) as f32;
            ex[2 * N * N + i] = (0.5 * lum + by) as f32;
        }
    }
    let class = (0..N * N)
        .map(|_| match rng.random_range(0..10) {
            0 => 2,
            1..=4 => 1,
            _ => 0,
        })
        .collect();
    (ex, class)
}

fn names() -> Vec<String> {
    ["L", "M", "S"].iter().map(|s| s.to_string()).collect()
}

/// Samples of a percept built from each of 10 synthetic scenes by `percept(excitation,
/// class) -> (dim, n, n)`.
pub(in crate::invariants) fn measure_samples(
    dim: usize,
    percept: impl Fn(&[f32], &[usize]) -> Vec<f32>,
) -> HiddenSamples {
    let mut rng = SmallRng::seed_from_u64(5);
    let mut samples = HiddenSamples::new(dim, 3);
    for _ in 0..10 {
        let (ex, class) = scene(&mut rng);
        samples.add(&percept(&ex, &class), &ex, &class, N, 2);
    }
    samples
}

/// Measures a percept built from each scene by `percept(excitation, class) -> (dim, n, n)`.
fn measure_with(dim: usize, percept: impl Fn(&[f32], &[usize]) -> Vec<f32>) -> HiddenRecovery {
    measure_samples(dim, percept).measure(&names())
}

#[test]
fn a_percept_of_every_class_everywhere_recovers_all_and_l_plus_m_recovers_no_s() {
    let full = measure_with(3, |ex, _| ex.to_vec());
    for r in &full.unique_r2 {
        assert!(
            *r > 0.999,
            "the true excitations recover every class: {full:?}"
        );
    }
    // L + M only, in a rotated 2-channel percept: S's unique part is not there, and of L's
    // and M's only the share their sum carries.
    let lum = measure_with(2, |ex, _| {
        let nn = N * N;
        let mut p = vec![0f32; 2 * nn];
        for i in 0..nn {
            let l = ex[i] + ex[nn + i];
            p[i] = 0.6 * l;
            p[nn + i] = -0.8 * l;
        }
        p
    });
    assert!(lum.unique_r2[2].abs() < 0.1, "no S in L + M: {lum:?}");
    for r in &lum.unique_r2[..2] {
        assert!(
            *r < 0.5,
            "L + M carries little of L's or M's own part: {lum:?}"
        );
    }
}

#[test]
fn a_percept_that_copies_the_mosaic_recovers_nothing_at_hidden_sites() {
    // Each class's excitation only where its own cone is (no interpolation): at the other
    // classes' cones the channel is zero, so nothing of the class is recovered there.
    let mosaic = measure_with(3, |ex, class| {
        let nn = N * N;
        let mut p = vec![0f32; 3 * nn];
        for (i, &c) in class.iter().enumerate() {
            p[c * nn + i] = ex[c * nn + i];
        }
        p
    });
    for r in &mosaic.unique_r2 {
        assert!(*r < 0.1, "a mosaic copy recovers little: {mosaic:?}");
    }
    // L and M interpolated everywhere, S dropped: S's own part is not recovered, and L's
    // and M's are recovered as far as S does not enter them.
    let dichromat = measure_with(2, |ex, _| ex[..2 * N * N].to_vec());
    assert!(dichromat.unique_r2[2].abs() < 0.1, "{dichromat:?}");
    assert!(
        dichromat.unique_r2[..2].iter().all(|r| *r > 0.3),
        "{dichromat:?}"
    );
}

#[test]
fn a_single_class_has_no_figure() {
    let mut samples = HiddenSamples::new(1, 1);
    for _ in 0..2 {
        samples.add(&[1.0; N * N], &[1.0; N * N], &[0; N * N], N, 1);
    }
    let r = samples.measure(&["L".to_string()]);
    assert!(r.unique_r2[0].is_nan(), "{r:?}");
}

/// Every cone inside the border up to 16 × 16 of them; beyond, the smallest step that keeps at
/// most that many: the quick eye (58 cones inside its border) every fourth, the `large` eye
/// (122) every eighth, the paper's (250) every sixteenth.
#[test]
fn the_site_stride_keeps_at_most_a_16_by_16_grid() {
    for (side, stride) in [(1, 1), (16, 1), (17, 2), (58, 4), (122, 8), (250, 16)] {
        assert_eq!(site_stride(side), stride, "side {side}");
    }
    for side in 1..600 {
        let s = site_stride(side);
        assert!(
            side.div_ceil(s).pow(2) <= MAX_SITES_PER_SAMPLE,
            "side {side}"
        );
        assert!(
            s == 1 || side.div_ceil(s - 1).pow(2) > MAX_SITES_PER_SAMPLE,
            "side {side}"
        );
    }
    let mut samples = HiddenSamples::new(1, 1);
    let n = 132;
    samples.add(&vec![0.0; n * n], &vec![0.0; n * n], &vec![0; n * n], n, 3);
    assert_eq!(samples.sites_per_sample(), 16 * 16);
}
