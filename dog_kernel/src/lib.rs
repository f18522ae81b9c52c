//! The difference-of-Gaussians (DoG) lateral-inhibition kernel on a square cone lattice
//! (authors' code, docs/references.md#lateral-inhibition, paper S-02).
//!
//! `K = Gc − w·Gs`: Gc and Gs are Gaussians of σc and σs lattice cells sampled on the integer
//! offsets of a `(size, size)` grid centred on the middle tap, each normalised to sum 1, and w
//! the surround weight, so `ΣK = 1 − w` (0.09 officially: the paper's "non-zero mean 0.09").
//! The side is `ceil(6·σs)` bumped to odd (7 for σs = 0.9). Layout: row-major f64, offsets
//! `(i − size/2, j − size/2)` in cells. K is symmetric, so convolution and correlation coincide.
//!
//! The retina applies it to cone activations (`retina::lateral_inhibition`); the cortex's
//! synthetic data source, which has no retina, applies the same kernel to its cone signals.
//! This crate is the one place both take it from.

/// Centre σ, lattice cells (authors' code, docs/references.md#lateral-inhibition).
pub const OFFICIAL_SIGMA_CENTRE_CELLS: f64 = 0.15;
/// Surround σ, lattice cells (authors' code, docs/references.md#lateral-inhibition).
pub const OFFICIAL_SIGMA_SURROUND_CELLS: f64 = 0.9;
/// Surround weight (authors' code, docs/references.md#lateral-inhibition), giving DC gain 1 − 0.91 = 0.09.
pub const OFFICIAL_SURROUND_WEIGHT: f64 = 0.91;

/// Kernel side for a surround σ of `sigma_surround_cells`: `ceil(6·σs)`, bumped to odd.
pub fn kernel_size(sigma_surround_cells: f64) -> usize {
    let s = (6.0 * sigma_surround_cells).ceil().max(1.0) as usize;
    if s.is_multiple_of(2) {
        s + 1
    } else {
        s
    }
}

/// The kernel `Gc − w·Gs`, `(size, size)` row-major with `size = kernel_size(σs)` (module
/// docs).
pub fn kernel(
    sigma_centre_cells: f64,
    sigma_surround_cells: f64,
    surround_weight: f64,
) -> Vec<f64> {
    let size = kernel_size(sigma_surround_cells);
    let (c, s) = (
        unit_gaussian(size, sigma_centre_cells),
        unit_gaussian(size, sigma_surround_cells),
    );
    c.iter()
        .zip(&s)
        .map(|(a, b)| a - surround_weight * b)
        .collect()
}

/// The official kernel (σc 0.15, σs 0.9, w 0.91): 7×7, sum 0.09.
pub fn official_kernel() -> Vec<f64> {
    kernel(
        OFFICIAL_SIGMA_CENTRE_CELLS,
        OFFICIAL_SIGMA_SURROUND_CELLS,
        OFFICIAL_SURROUND_WEIGHT,
    )
}

/// A Gaussian of σ `sigma` cells sampled on the `(size, size)` integer offsets around the
/// middle tap, row-major, normalised to sum 1.
fn unit_gaussian(size: usize, sigma: f64) -> Vec<f64> {
    let r = (size / 2) as f64;
    let mut g: Vec<f64> = (0..size * size)
        .map(|i| {
            let (y, x) = ((i / size) as f64 - r, (i % size) as f64 - r);
            (-(x * x + y * y) / (2.0 * sigma * sigma)).exp()
        })
        .collect();
    let s: f64 = g.iter().sum();
    g.iter_mut().for_each(|v| *v /= s);
    g
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn official_kernel_is_7x7_with_dc_gain_0_09_and_the_documented_taps() {
        assert_eq!(kernel_size(OFFICIAL_SIGMA_SURROUND_CELLS), 7);
        let k = official_kernel();
        assert_eq!(k.len(), 49);
        let sum: f64 = k.iter().sum();
        assert!((sum - 0.09).abs() < 1e-12, "{sum}");
        // centre ≈ 0.821, nearest neighbours ≈ −0.0965, diagonals ≈ −0.052
        assert!((k[24] - 0.821).abs() < 1e-3, "{}", k[24]);
        assert!((k[23] + 0.0965).abs() < 1e-3, "{}", k[23]);
        assert!((k[16] + 0.052).abs() < 1e-3, "{}", k[16]);
    }

    #[test]
    fn kernel_is_symmetric_under_flips_and_transposition() {
        let k = kernel(0.3, 1.3, 0.5);
        let n = kernel_size(1.3);
        assert_eq!(n, 9);
        for i in 0..n {
            for j in 0..n {
                let v = k[i * n + j];
                assert_eq!(v, k[j * n + i]);
                assert_eq!(v, k[(n - 1 - i) * n + j]);
                assert_eq!(v, k[i * n + (n - 1 - j)]);
            }
        }
    }

    #[test]
    fn even_sides_are_bumped_to_odd() {
        assert_eq!(kernel_size(1.0), 7);
        assert_eq!(kernel_size(0.5), 3);
        assert_eq!(kernel_size(0.01), 1);
    }
}
