//! Plain (tape-free) resampling on the normalised grid, with the same semantics as the tape's
//! `grid_sample`: align-corners (u = −1 is the centre of column 0, u = +1 the centre of column
//! n−1), bilinear, zeros outside; the validity mask is a nearest-neighbour sample of ones.
//!
//! Points are `[u, v]` = `[x (column), y (row)]`.

/// The normalised coordinate of pixel index `i` on an axis of `n` pixels (align-corners).
#[inline]
pub fn index_to_unit(i: usize, n: usize) -> f64 {
    if n == 1 {
        0.0
    } else {
        -1.0 + 2.0 * i as f64 / (n - 1) as f64
    }
}

/// The pixel coordinate (fractional) of normalised `u` on an axis of `n` pixels.
#[inline]
pub fn unit_to_index(u: f64, n: usize) -> f64 {
    (u + 1.0) * 0.5 * (n as f64 - 1.0)
}

/// The `n×n` ONS grid as points, row-major (`[u_x, u_y]`).
pub fn unit_grid(n: usize) -> Vec<[f64; 2]> {
    let mut g = Vec::with_capacity(n * n);
    for y in 0..n {
        for x in 0..n {
            g.push([index_to_unit(x, n), index_to_unit(y, n)]);
        }
    }
    g
}

/// Bilinear sample of the `h×w` image `img` at normalised point `p` (zeros outside).
#[inline]
pub fn bilinear(img: &[f32], h: usize, w: usize, p: [f64; 2]) -> f64 {
    bilinear_at(img, h, w, BilinearTap::new(h, w, p))
}

/// Where a bilinear sample reads: the top-left pixel `(x0, y0)` (column, row; may lie outside)
/// and the fractions `fx, fy ∈ [0, 1)` towards the next column and row. Computing it once per
/// point and reusing it for several images gives exactly [`bilinear`]'s values.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BilinearTap {
    pub x0: isize,
    pub y0: isize,
    pub fx: f64,
    pub fy: f64,
}

impl BilinearTap {
    /// The tap of normalised point `p` on an `h×w` image.
    #[inline]
    pub fn new(h: usize, w: usize, p: [f64; 2]) -> Self {
        let x = unit_to_index(p[0], w);
        let y = unit_to_index(p[1], h);
        let (x0, y0) = (x.floor(), y.floor());
        BilinearTap {
            x0: x0 as isize,
            y0: y0 as isize,
            fx: x - x0,
            fy: y - y0,
        }
    }
}

/// Bilinear sample of the `h×w` image `img` through a precomputed tap (zeros outside).
#[inline]
pub fn bilinear_at(img: &[f32], h: usize, w: usize, t: BilinearTap) -> f64 {
    let BilinearTap { x0, y0, fx, fy } = t;
    let at = |yy: isize, xx: isize| -> f64 {
        if yy >= 0 && xx >= 0 && (yy as usize) < h && (xx as usize) < w {
            img[yy as usize * w + xx as usize] as f64
        } else {
            0.0
        }
    };
    (1.0 - fy) * ((1.0 - fx) * at(y0, x0) + fx * at(y0, x0 + 1))
        + fy * ((1.0 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1))
}

/// 1 when the nearest pixel of `p` (rounding half to even, like the tape's `grid_sample_mask`)
/// lies inside an `h×w` image, else 0.
#[inline]
pub fn nearest_inside(h: usize, w: usize, p: [f64; 2]) -> bool {
    let x = unit_to_index(p[0], w).round_ties_even();
    let y = unit_to_index(p[1], h).round_ties_even();
    x >= 0.0 && y >= 0.0 && x <= (w - 1) as f64 && y <= (h - 1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_points_sample_their_own_pixels() {
        let n = 5;
        let img: Vec<f32> = (0..n * n).map(|i| i as f32).collect();
        for (i, p) in unit_grid(n).into_iter().enumerate() {
            assert!((bilinear(&img, n, n, p) - i as f64).abs() < 1e-9);
            assert!(nearest_inside(n, n, p));
        }
        // halfway between columns 1 and 2 of row 3
        let p = [
            index_to_unit(1, n) + 1.0 / (n - 1) as f64,
            index_to_unit(3, n),
        ];
        assert!((bilinear(&img, n, n, p) - 16.5).abs() < 1e-9);
        assert!(!nearest_inside(n, n, [1.3, 0.0]));
        assert_eq!(bilinear(&img, n, n, [3.0, 0.0]), 0.0);
    }
}
