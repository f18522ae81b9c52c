//! Tests of lateral inhibition: the official kernel, inversion, the FFT path against the direct one, zero padding and noise.

use super::*;
use rand::rngs::StdRng;
use rand::SeedableRng;

#[test]
fn official_kernel_numbers() {
    let c = DogConfig::default();
    assert_eq!(c.kernel_size(), 7);
    let li = LateralInhibition::new(c, 16);
    assert!((li.dc_gain() - 0.09).abs() < 1e-12, "{}", li.dc_gain());
    let k = &li.kernel;
    assert!((k[3 * 7 + 3] - 0.821).abs() < 1e-3, "centre {}", k[24]);
    assert!((k[3 * 7 + 4] + 0.0965).abs() < 1e-3, "neighbour {}", k[25]);
    assert!((k[2 * 7 + 2] + 0.052).abs() < 1e-3, "diagonal {}", k[16]);
}

#[test]
fn invert_recovers_the_activations_and_fails_for_another_kernel() {
    let mut rng = StdRng::seed_from_u64(5);
    for n in [7usize, 32, 64] {
        let li = LateralInhibition::new(DogConfig::default(), n);
        let x: Vec<f32> = (0..n * n).map(|_| rng.random::<f32>() * 1.1).collect();
        let mut ons = vec![0.0; n * n];
        li.compute_direct(&x, &mut ons);
        let mut back = vec![0.0; n * n];
        let residual = li.invert(&ons, &mut back, 1e-9, 500);
        assert!(residual <= 1e-9, "n = {n}: residual {residual}");
        let worst = x
            .iter()
            .zip(&back)
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(worst < 1e-5, "n = {n}: max |x − invert(LI x)| = {worst}");
        // The inverse of a different DoG does not recover x: the test can fail.
        let other = LateralInhibition::new(
            DogConfig {
                surround_weight: 0.5,
                ..DogConfig::default()
            },
            n,
        );
        other.invert(&ons, &mut back, 1e-9, 500);
        let worst = x
            .iter()
            .zip(&back)
            .map(|(a, b)| (a - b).abs())
            .fold(0f32, f32::max);
        assert!(
            worst > 1e-2,
            "n = {n}: a wrong kernel inverted too well ({worst})"
        );
    }
}

#[test]
fn fft_path_equals_direct_to_1e6() {
    let mut rng = StdRng::seed_from_u64(3);
    for n in [5usize, 32, 64] {
        let li = LateralInhibition::new(DogConfig::default(), n);
        let x: Vec<f32> = (0..n * n).map(|_| rng.random::<f32>() * 1.1).collect();
        let (mut a, mut b) = (vec![0.0; n * n], vec![0.0; n * n]);
        li.compute_direct(&x, &mut a);
        li.compute_fft(&x, &mut b);
        let err = a
            .iter()
            .zip(&b)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0f32, f32::max);
        assert!(err <= 1e-6, "n {n}: max |direct − fft| = {err}");
    }
}

#[test]
fn convolution_is_zero_padded_same() {
    // An impulse in the corner gives the kernel's lower-right quadrant; a constant image
    // gives 0.09 inside and less near the zero-padded border.
    let n = 9;
    let li = LateralInhibition::new(DogConfig::default(), n);
    let mut x = vec![0.0f32; n * n];
    x[0] = 1.0;
    let mut y = vec![0.0; n * n];
    li.compute_direct(&x, &mut y);
    for dy in 0..4 {
        for dx in 0..4 {
            let k = li.kernel[(3 + dy) * 7 + 3 + dx] as f32;
            assert!((y[dy * n + dx] - k).abs() < 1e-7);
        }
    }
    assert!(y[4 * n + 4].abs() < 1e-12 && y[5].abs() < 1e-12);
    let ones = vec![1.0f32; n * n];
    li.compute_direct(&ones, &mut y);
    assert!((y[4 * n + 4] - 0.09).abs() < 1e-6);
    assert!(y[0] > 0.09 + 0.1);
}

#[test]
fn multiplicative_noise_scale() {
    let mut rng = StdRng::seed_from_u64(0);
    let mut x = vec![2.0f32; 100_000];
    add_multiplicative_noise(&mut rng, &mut x, 0.01, 1.0);
    let sd = (x.iter().map(|&v| ((v - 2.0) as f64).powi(2)).sum::<f64>() / 1e5).sqrt();
    assert!((sd - 0.02).abs() < 0.0005, "{sd}");
}
