use super::*;
use rand::rngs::StdRng;
use rand::SeedableRng;
use rand_distr::{Distribution, StandardNormal};

fn white(dims: &[usize], seed: u64) -> Tensor<f64> {
    let mut rng = StdRng::seed_from_u64(seed);
    Tensor::from_fn(dims, |_| StandardNormal.sample(&mut rng))
}

fn rms(t: &Tensor<f64>) -> f64 {
    (t.sum_sq() / t.numel() as f64).sqrt()
}

/// A (2, 2, 4, 4) activation fed back from a (2, 1, 8, 8) output: block means, then the
/// k × k kernel, checked against the formula at one unit; a finer activation repeats.
#[test]
fn image_feedback_is_a_random_convolution_of_the_resampled_error() {
    let mut dfa = DirectFeedbackAlignment::<f64>::new(3);
    let e = Tensor::from_fn([2, 1, 8, 8], |i| (i as f64 * 0.3).sin());
    let mut g = Tensor::zeros([2, 2, 4, 4]);
    dfa.project("h", &e, &mut g);
    let k = dfa.feedback.values().next().unwrap().clone();
    assert_eq!(k.dims(), &[2, 1, 3, 3]);
    let e_hat = |y: usize, x: usize| {
        let at = |yy: usize, xx: usize| e.data()[64 + yy * 8 + xx];
        (at(2 * y, 2 * x) + at(2 * y, 2 * x + 1) + at(2 * y + 1, 2 * x) + at(2 * y + 1, 2 * x + 1))
            / 4.0
    };
    // sample 1, channel 1, cell (0, 1): rows −1 and columns outside are zero padding
    let mut want = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            let (y, x) = (i as isize - 1, 1 + j as isize - 1);
            if (0..4).contains(&y) && (0..4).contains(&x) {
                want += k.data()[9 + i * 3 + j] * e_hat(y as usize, x as usize);
            }
        }
    }
    let got = g.data()[((2 + 1) * 4) * 4 + 1];
    assert!((got - want).abs() < 1e-12, "{got} vs {want}");
    let mut fine = Tensor::zeros([2, 2, 16, 16]);
    dfa.project("h", &e, &mut fine);
    let resampled = project::resample("h", &e, 16, 16);
    assert_eq!(
        resampled.data()[16 + 3],
        e.data()[1],
        "each error pixel covers 2×2"
    );
}

#[test]
fn feedback_has_the_rms_of_the_error_at_every_width() {
    for (channels, side, k) in [(16, 16, 3), (64, 8, 3), (32, 8, 5)] {
        let mut dfa = DirectFeedbackAlignment::<f64>::new(11).with_kernel_px(k);
        let e = white(&[8, 1, side, side], 2);
        let mut g = Tensor::zeros([8, channels, side, side]);
        dfa.project("h", &e, &mut g);
        // zero padding loses part of the kernel at the border: compare the interior
        let r = k / 2;
        let interior: Vec<f64> = (0..g.numel())
            .filter(|&i| {
                let (x, y) = (i % side, (i / side) % side);
                (r..side - r).contains(&x) && (r..side - r).contains(&y)
            })
            .map(|i| g.data()[i])
            .collect();
        let got = (interior.iter().map(|v| v * v).sum::<f64>() / interior.len() as f64).sqrt();
        let ratio = got / rms(&e);
        assert!(
            (0.8..1.25).contains(&ratio),
            "{channels} channels, k {k}: feedback RMS / error RMS = {ratio}"
        );
    }
    let mut dfa = DirectFeedbackAlignment::<f64>::new(11);
    let e = white(&[64, 10], 3);
    let mut g = Tensor::zeros([64, 200]);
    dfa.project("dense", &e, &mut g);
    let ratio = rms(&g) / rms(&e);
    assert!((0.85..1.15).contains(&ratio), "dense: {ratio}");
}

#[test]
fn each_channel_receives_its_own_map() {
    let mut dfa = DirectFeedbackAlignment::<f64>::new(1);
    let e = white(&[1, 1, 8, 8], 5);
    let mut g = Tensor::zeros([1, 4, 8, 8]);
    dfa.project("h", &e, &mut g);
    let plane = |c: usize| &g.data()[c * 64..(c + 1) * 64];
    // not one map times a scalar per channel: the ratio between two channels varies
    let ratios: Vec<f64> = (0..64).map(|i| plane(1)[i] / plane(0)[i]).collect();
    let spread = ratios.iter().cloned().fold(f64::MIN, f64::max)
        - ratios.iter().cloned().fold(f64::MAX, f64::min);
    assert!(spread > 0.5, "channels 0 and 1 differ by a scalar only");
}

#[test]
fn feedback_depends_only_on_seed_tag_and_shapes_and_survives_its_state() {
    let e = Tensor::from_fn([3, 2], |i| i as f64 - 2.0);
    let proj = |dfa: &mut DirectFeedbackAlignment<f64>, tag: &'static str| {
        let mut g = Tensor::zeros([3, 5]);
        dfa.project(tag, &e, &mut g);
        g
    };
    let new = DirectFeedbackAlignment::<f64>::new;
    assert_eq!(proj(&mut new(1), "a"), proj(&mut new(1), "a"));
    assert_ne!(proj(&mut new(1), "a"), proj(&mut new(2), "a"));
    assert_ne!(proj(&mut new(1), "a"), proj(&mut new(1), "b"));
    let mut saved = new(1);
    let g = proj(&mut saved, "a");
    let state = saved.state(&ParamStore::new());
    assert_eq!(state.tensors.keys().next().unwrap(), "feedback|a|5|2");
    let mut other_seed = new(9);
    other_seed.load_state(&state, &ParamStore::new()).unwrap();
    assert_eq!(
        proj(&mut other_seed, "a"),
        g,
        "the loaded projection is used"
    );
}

#[test]
#[should_panic(expected = "tag h: activation (B, [4]) and output (B, [1, 2, 2])")]
fn mixed_ranks_panic_naming_the_tag() {
    let mut g = Tensor::zeros([1, 4]);
    DirectFeedbackAlignment::<f64>::new(1).project("h", &Tensor::zeros([1, 1, 2, 2]), &mut g);
}
