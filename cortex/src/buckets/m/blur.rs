//! B, the low-pass operator of motion estimation (authors' code, docs/references.md#motion-estimation; paper S-03 "B"): a separable
//! Gaussian of side `k` (official 9) and σ (official 2 px) with reflect padding of ⌊k/2⌋, which
//! roughly halves the highest frequencies. Plain f32 → f32, no gradients (M runs under no-grad).
//!
//! Layout: `(B, n, n)` planes, row-major. Reflect padding mirrors without repeating the edge
//! (PyTorch `reflect`): index −1 reads 1.

use rayon::prelude::*;

/// Normalised 1-D Gaussian taps of odd length `k`.
pub fn gaussian_taps(k: usize, sigma_px: f64) -> Vec<f32> {
    assert!(k % 2 == 1, "gaussian_taps: k = {k} must be odd");
    let r = (k / 2) as f64;
    let w: Vec<f64> = (0..k)
        .map(|i| (-((i as f64 - r).powi(2)) / (2.0 * sigma_px * sigma_px)).exp())
        .collect();
    let s: f64 = w.iter().sum();
    w.iter().map(|v| (v / s) as f32).collect()
}

#[inline]
fn reflect(i: isize, n: isize) -> usize {
    let mut i = i;
    if i < 0 {
        i = -i;
    }
    if i >= n {
        i = 2 * (n - 1) - i;
    }
    i.clamp(0, n - 1) as usize
}

/// Blurs each `n×n` plane of `src` into `dst` (same length, a multiple of n²).
pub fn blur_planes(src: &[f32], dst: &mut [f32], n: usize, k: usize, sigma_px: f64) {
    assert_eq!(
        src.len(),
        dst.len(),
        "blur_planes: src {} vs dst {} values",
        src.len(),
        dst.len()
    );
    assert!(
        src.len().is_multiple_of(n * n),
        "blur_planes: {} values is not a whole number of {n}×{n} planes",
        src.len()
    );
    assert!(
        k / 2 < n,
        "blur_planes: kernel {k} needs n > {}, got {n}",
        k / 2
    );
    let taps = gaussian_taps(k, sigma_px);
    let r = (k / 2) as isize;
    dst.par_chunks_mut(n * n)
        .zip(src.par_chunks(n * n))
        .for_each(|(out, img)| {
            let mut tmp = vec![0.0f32; n * n];
            for y in 0..n {
                let row = &img[y * n..(y + 1) * n];
                for x in 0..n {
                    let mut s = 0.0;
                    for (t, w) in taps.iter().enumerate() {
                        s += w * row[reflect(x as isize + t as isize - r, n as isize)];
                    }
                    tmp[y * n + x] = s;
                }
            }
            for y in 0..n {
                for x in 0..n {
                    let mut s = 0.0;
                    for (t, w) in taps.iter().enumerate() {
                        s += w * tmp[reflect(y as isize + t as isize - r, n as isize) * n + x];
                    }
                    out[y * n + x] = s;
                }
            }
        });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constant_stays_constant_and_impulse_spreads_as_a_gaussian() {
        let n = 16;
        let src = vec![2.0f32; n * n];
        let mut dst = vec![0.0; n * n];
        blur_planes(&src, &mut dst, n, 9, 2.0);
        assert!(dst.iter().all(|v| (v - 2.0).abs() < 1e-5));
        let mut imp = vec![0.0f32; n * n];
        imp[8 * n + 8] = 1.0;
        blur_planes(&imp, &mut dst, n, 9, 2.0);
        let taps = gaussian_taps(9, 2.0);
        assert!((dst[8 * n + 8] - taps[4] * taps[4]).abs() < 1e-6);
        assert!((dst[8 * n + 10] - taps[4] * taps[6]).abs() < 1e-6);
        assert!((taps[6] / taps[4] - (-0.5f32).exp()).abs() < 1e-6);
    }

    #[test]
    fn reflect_padding_mirrors_without_the_edge() {
        assert_eq!(reflect(-1, 5), 1);
        assert_eq!(reflect(5, 5), 3);
        assert_eq!(reflect(2, 5), 2);
    }
}
