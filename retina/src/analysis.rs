//! Image statistics the tests and [`crate::scene::statistics`] use: spectral principal
//! components, radially averaged power spectra, correlation.
//!
//! - [`pca_components_for_variance`]: eigenvalues of the covariance (mean removed) of pixel
//!   spectra; the smallest number of components whose eigenvalues hold the given fraction of the
//!   total variance. Jacobi eigenvalue iteration (the matrices are wavelengths², ≈ 31²).
//! - [`power_spectrum_slope`]: a square plane, mean removed, Hann-windowed (so the image border
//!   does not add a spurious f^(−2) cross), 2-D FFT; power averaged over rings of integer radius
//!   (cycles per image); least-squares slope of log power on log frequency between
//!   `f_min_cycles` and `f_max_fraction`·N/2. Natural images give about −2 (Field 1987; van der
//!   Schaaf & van Hateren 1996: −1.6 … −2.4).
//! - [`pearson`]: correlation coefficient.

use rustfft::num_complex::Complex64;
use rustfft::FftPlanner;

/// Eigenvalues of a symmetric `d × d` matrix (row-major), descending. Cyclic Jacobi.
pub fn symmetric_eigenvalues(a: &[f64], d: usize) -> Vec<f64> {
    assert_eq!(
        a.len(),
        d * d,
        "symmetric_eigenvalues: {} values for {d}×{d}",
        a.len()
    );
    let mut m = a.to_vec();
    for _sweep in 0..100 {
        let off: f64 = (0..d)
            .flat_map(|i| (0..d).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| m[i * d + j].powi(2))
            .sum();
        let scale: f64 = (0..d)
            .map(|i| m[i * d + i].powi(2))
            .sum::<f64>()
            .max(1e-300);
        if off <= 1e-24 * scale {
            break;
        }
        for p in 0..d {
            for q in p + 1..d {
                let apq = m[p * d + q];
                if apq.abs() < 1e-300 {
                    continue;
                }
                let theta = (m[q * d + q] - m[p * d + p]) / (2.0 * apq);
                let t = theta.signum() / (theta.abs() + (theta * theta + 1.0).sqrt());
                let t = if theta == 0.0 { 1.0 } else { t };
                let c = 1.0 / (t * t + 1.0).sqrt();
                let s = t * c;
                for k in 0..d {
                    let (akp, akq) = (m[k * d + p], m[k * d + q]);
                    m[k * d + p] = c * akp - s * akq;
                    m[k * d + q] = s * akp + c * akq;
                }
                for k in 0..d {
                    let (apk, aqk) = (m[p * d + k], m[q * d + k]);
                    m[p * d + k] = c * apk - s * aqk;
                    m[q * d + k] = s * apk + c * aqk;
                }
            }
        }
    }
    let mut ev: Vec<f64> = (0..d).map(|i| m[i * d + i]).collect();
    ev.sort_by(|a, b| b.total_cmp(a));
    ev
}

/// Covariance eigenvalues (descending) of `samples` spectra of length `d`, given as planar
/// `(d, count)` data (the layout of a spectral image: wavelength planes).
pub fn spectral_covariance_eigenvalues(planar: &[f32], d: usize) -> Vec<f64> {
    assert!(
        d > 0 && planar.len().is_multiple_of(d),
        "spectral_covariance_eigenvalues: shape"
    );
    let count = planar.len() / d;
    let mean: Vec<f64> = (0..d)
        .map(|l| {
            planar[l * count..(l + 1) * count]
                .iter()
                .map(|&v| v as f64)
                .sum::<f64>()
                / count as f64
        })
        .collect();
    let mut cov = vec![0.0f64; d * d];
    for i in 0..d {
        for j in i..d {
            let (a, b) = (
                &planar[i * count..(i + 1) * count],
                &planar[j * count..(j + 1) * count],
            );
            let s: f64 = a
                .iter()
                .zip(b)
                .map(|(&x, &y)| (x as f64 - mean[i]) * (y as f64 - mean[j]))
                .sum();
            cov[i * d + j] = s / count as f64;
            cov[j * d + i] = cov[i * d + j];
        }
    }
    symmetric_eigenvalues(&cov, d)
}

/// Smallest number of leading eigenvalues holding `fraction` of their sum.
pub fn components_for_fraction(eigenvalues_desc: &[f64], fraction: f64) -> usize {
    let total: f64 = eigenvalues_desc.iter().map(|v| v.max(0.0)).sum();
    let mut acc = 0.0;
    for (i, v) in eigenvalues_desc.iter().enumerate() {
        acc += v.max(0.0);
        if acc >= fraction * total {
            return i + 1;
        }
    }
    eigenvalues_desc.len()
}

/// [`spectral_covariance_eigenvalues`] then [`components_for_fraction`].
pub fn pca_components_for_variance(planar: &[f32], d: usize, fraction: f64) -> usize {
    components_for_fraction(&spectral_covariance_eigenvalues(planar, d), fraction)
}

/// Radially averaged power spectrum of a square `n × n` plane: `(frequency in cycles per
/// image, mean power)` for integer radii 1 … n/2 (module docs).
pub fn radial_power_spectrum(plane: &[f32], n: usize) -> Vec<(f64, f64)> {
    assert_eq!(
        plane.len(),
        n * n,
        "radial_power_spectrum: {} values for {n}²",
        plane.len()
    );
    let mean = plane.iter().map(|&v| v as f64).sum::<f64>() / (n * n) as f64;
    let hann: Vec<f64> = (0..n)
        .map(|i| 0.5 - 0.5 * (2.0 * std::f64::consts::PI * i as f64 / n as f64).cos())
        .collect();
    let mut buf: Vec<Complex64> = (0..n * n)
        .map(|p| Complex64::new((plane[p] as f64 - mean) * hann[p / n] * hann[p % n], 0.0))
        .collect();
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n);
    fft.process(&mut buf);
    let mut t = vec![Complex64::new(0.0, 0.0); n * n];
    for y in 0..n {
        for x in 0..n {
            t[x * n + y] = buf[y * n + x];
        }
    }
    fft.process(&mut t);
    let half = n / 2;
    let mut sum = vec![0.0f64; half + 1];
    let mut cnt = vec![0usize; half + 1];
    for fy in 0..n {
        for fx in 0..n {
            let ky = if fy <= half {
                fy as f64
            } else {
                fy as f64 - n as f64
            };
            let kx = if fx <= half {
                fx as f64
            } else {
                fx as f64 - n as f64
            };
            let r = kx.hypot(ky).round() as usize;
            if r >= 1 && r <= half {
                sum[r] += t[fx * n + fy].norm_sqr();
                cnt[r] += 1;
            }
        }
    }
    (1..=half)
        .filter(|&r| cnt[r] > 0)
        .map(|r| (r as f64, sum[r] / cnt[r] as f64))
        .collect()
}

/// Least-squares slope of log power on log frequency over `[f_min_cycles, f_max_fraction·n/2]`.
pub fn power_spectrum_slope(
    plane: &[f32],
    n: usize,
    f_min_cycles: f64,
    f_max_fraction: f64,
) -> f64 {
    let ps = radial_power_spectrum(plane, n);
    let fmax = f_max_fraction * (n / 2) as f64;
    let pts: Vec<(f64, f64)> = ps
        .into_iter()
        .filter(|&(f, p)| f >= f_min_cycles && f <= fmax && p > 0.0)
        .map(|(f, p)| (f.ln(), p.ln()))
        .collect();
    assert!(
        pts.len() >= 3,
        "power_spectrum_slope: fewer than 3 frequencies in range"
    );
    let m = pts.len() as f64;
    let (sx, sy) = pts.iter().fold((0.0, 0.0), |a, p| (a.0 + p.0, a.1 + p.1));
    let (mx, my) = (sx / m, sy / m);
    let (num, den) = pts.iter().fold((0.0, 0.0), |a, p| {
        (a.0 + (p.0 - mx) * (p.1 - my), a.1 + (p.0 - mx).powi(2))
    });
    num / den
}

/// Pearson correlation of two equally long series.
pub fn pearson(a: &[f32], b: &[f32]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "pearson: lengths {} and {}",
        a.len(),
        b.len()
    );
    let n = a.len() as f64;
    let ma = a.iter().map(|&v| v as f64).sum::<f64>() / n;
    let mb = b.iter().map(|&v| v as f64).sum::<f64>() / n;
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (&x, &y) in a.iter().zip(b) {
        let (dx, dy) = (x as f64 - ma, y as f64 - mb);
        sab += dx * dy;
        saa += dx * dx;
        sbb += dy * dy;
    }
    sab / (saa * sbb).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};

    #[test]
    fn jacobi_finds_known_eigenvalues() {
        // Q·diag(5, 2, 0.5)·Qᵀ with a rotation Q.
        let (c, s) = (0.6f64, 0.8f64);
        let q = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]];
        let d = [5.0, 2.0, 0.5];
        let mut a = vec![0.0; 9];
        for i in 0..3 {
            for j in 0..3 {
                a[i * 3 + j] = (0..3).map(|k| q[i][k] * d[k] * q[j][k]).sum();
            }
        }
        let ev = symmetric_eigenvalues(&a, 3);
        for (x, y) in ev.iter().zip([5.0, 2.0, 0.5]) {
            assert!((x - y).abs() < 1e-10);
        }
        assert_eq!(components_for_fraction(&ev, 0.99), 3);
        assert_eq!(components_for_fraction(&ev, 0.9), 2);
    }

    #[test]
    fn rank_two_data_needs_two_components() {
        let mut rng = StdRng::seed_from_u64(0);
        let (d, count) = (8, 2000);
        let b1: Vec<f32> = (0..d).map(|i| i as f32).collect();
        let b2: Vec<f32> = (0..d).map(|i| ((i * 3) % 5) as f32).collect();
        let mut planar = vec![0.0f32; d * count];
        for p in 0..count {
            let (u, v) = (rng.random::<f32>(), rng.random::<f32>());
            for l in 0..d {
                planar[l * count + p] = u * b1[l] + v * b2[l];
            }
        }
        assert_eq!(pca_components_for_variance(&planar, d, 0.9999), 2);
    }

    #[test]
    fn white_noise_is_flat_and_pearson_is_sane() {
        let mut rng = StdRng::seed_from_u64(1);
        let n = 128;
        let w: Vec<f32> = (0..n * n).map(|_| rng.random::<f32>()).collect();
        let s = power_spectrum_slope(&w, n, 4.0, 0.8);
        assert!(s.abs() < 0.15, "white-noise slope {s}");
        let a = [1.0f32, 2.0, 3.0, 4.0];
        assert!((pearson(&a, &[2.0, 4.0, 6.0, 8.0]) - 1.0).abs() < 1e-12);
        assert!((pearson(&a, &[4.0, 3.0, 2.0, 1.0]) + 1.0).abs() < 1e-12);
    }
}
