//! Multi-octave Perlin gradient noise (Perlin 1985), the positional jitter of the cone lattice.
//!
//! One octave on a `(rows, cols)` array with `(res_rows, res_cols)` noise periods: random unit
//! gradients at the `(res+1)²` lattice corners (angles uniform in [0, 2π)), dot products with the
//! offsets to the four corners, blended with the quintic fade `6t⁵ − 15t⁴ + 10t³`, times √2 —
//! the public-domain algorithm the official code uses (authors' code, docs/references.md#foveation, step 2). Octaves:
//! the resolution doubles and the amplitude is multiplied by the persistence each octave. The
//! official call is 6 octaves from resolution (2, 2) with persistence 0.8 on the 512² lattice,
//! which gives a std of about 0.5 lattice cells.
//!
//! Output layout: row-major `(rows, cols)`, f64, in lattice cells. Noise is 0 at every corner of
//! the noise lattice, so the sum over octaves is a smooth field with mean ≈ 0.

use rand::Rng;
use std::f64::consts::{PI, SQRT_2};

/// Number of octaves (authors' code, docs/references.md#foveation).
pub const OFFICIAL_OCTAVES: usize = 6;
/// Amplitude ratio between successive octaves (authors' code, docs/references.md#foveation).
pub const OFFICIAL_PERSISTENCE: f64 = 0.8;
/// Noise periods across the official 512-cell lattice in the first octave (authors' code, docs/references.md#foveation).
pub const OFFICIAL_BASE_RESOLUTION: usize = 2;

fn fade(t: f64) -> f64 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// One octave of gradient noise over `rows × cols` with `res` periods along each axis.
pub fn perlin_octave<R: Rng + ?Sized>(
    rng: &mut R,
    rows: usize,
    cols: usize,
    res_rows: usize,
    res_cols: usize,
) -> Vec<f64> {
    // −0.0 + x is x bit for bit (0.0 + −0.0 would be +0.0).
    let mut out = vec![-0.0; rows * cols];
    add_octave(rng, (rows, cols), (res_rows, res_cols), 1.0, &mut out);
    out
}

/// The random unit gradients at the `(res_rows + 1) × (res_cols + 1)` lattice corners,
/// row-major, as `(x, y)`: angles uniform in [0, 2π), drawn in that order from `rng`.
fn gradients<R: Rng + ?Sized>(
    rng: &mut R,
    (res_rows, res_cols): (usize, usize),
) -> Vec<(f64, f64)> {
    (0..(res_rows + 1) * (res_cols + 1))
        .map(|_| {
            let a = rng.random::<f64>() * 2.0 * PI;
            (a.cos(), a.sin())
        })
        .collect()
}

/// Where one grid coordinate falls on the noise lattice: its cell, its offsets from the cell's
/// two corners (`f`, `f − 1`) and the fade of `f`.
#[derive(Clone, Copy)]
struct LatticePlace {
    cell: usize,
    from_first: f64,
    from_second: f64,
    fade: f64,
}

impl LatticePlace {
    /// Coordinate `i` of `len` on a lattice of `res` periods.
    fn of(i: usize, len: usize, res: usize) -> Self {
        let g = i as f64 * res as f64 / len as f64;
        let f = g - g.floor();
        LatticePlace {
            cell: g.floor() as usize,
            from_first: f,
            from_second: f - 1.0,
            fade: fade(f),
        }
    }
}

/// Adds `amplitude ×` one octave (as [`perlin_octave`] draws it from `rng`) to `out`, row-major
/// `(rows, cols)`. Each column's place on the lattice is found once, not once a row.
fn add_octave<R: Rng + ?Sized>(
    rng: &mut R,
    (rows, cols): (usize, usize),
    (res_rows, res_cols): (usize, usize),
    amplitude: f64,
    out: &mut [f64],
) {
    assert!(
        res_rows > 0 && res_cols > 0,
        "perlin_octave: resolution {res_rows}×{res_cols} must be positive"
    );
    assert_eq!(out.len(), rows * cols, "perlin: output of {rows}×{cols}");
    let gw = res_cols + 1;
    let grads = gradients(rng, (res_rows, res_cols));
    let columns: Vec<LatticePlace> = (0..cols)
        .map(|c| LatticePlace::of(c, cols, res_cols))
        .collect();
    for (r, row) in out.chunks_exact_mut(cols.max(1)).enumerate().take(rows) {
        let y = LatticePlace::of(r, rows, res_rows);
        let (near, far) = (&grads[y.cell * gw..], &grads[(y.cell + 1) * gw..]);
        for (o, x) in row.iter_mut().zip(&columns) {
            let dot = |(gx, gy): (f64, f64), dx: f64, dy: f64| gx * dx + gy * dy;
            let n0 = dot(near[x.cell], x.from_first, y.from_first);
            let n1 = dot(near[x.cell + 1], x.from_second, y.from_first);
            let f0 = dot(far[x.cell], x.from_first, y.from_second);
            let f1 = dot(far[x.cell + 1], x.from_second, y.from_second);
            let top = n0 + x.fade * (n1 - n0);
            let bottom = f0 + x.fade * (f1 - f0);
            *o += amplitude * (SQRT_2 * (top + y.fade * (bottom - top)));
        }
    }
}

/// Sum of `octaves` octaves: resolution `base_res·2^k`, amplitude `persistence^k`.
pub fn perlin_octaves<R: Rng + ?Sized>(
    rng: &mut R,
    rows: usize,
    cols: usize,
    base_res: usize,
    octaves: usize,
    persistence: f64,
) -> Vec<f64> {
    let mut out = vec![0.0; rows * cols];
    let mut amplitude = 1.0;
    let mut res = base_res;
    for _ in 0..octaves {
        add_octave(rng, (rows, cols), (res, res), amplitude, &mut out);
        amplitude *= persistence;
        res *= 2;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::SeedableRng;

    /// One octave as first written: every pixel finds its lattice place and its four dot
    /// products on its own (the reference the column-wise [`add_octave`] must equal bit for bit).
    fn reference_octave(
        rng: &mut StdRng,
        (rows, cols): (usize, usize),
        (res_rows, res_cols): (usize, usize),
    ) -> Vec<f64> {
        let gw = res_cols + 1;
        let grads = gradients(rng, (res_rows, res_cols));
        let mut out = vec![0.0; rows * cols];
        for r in 0..rows {
            let gy = r as f64 * res_rows as f64 / rows as f64;
            let (cy, fy) = (gy.floor() as usize, gy - gy.floor());
            let ty = fade(fy);
            for c in 0..cols {
                let gx = c as f64 * res_cols as f64 / cols as f64;
                let (cx, fx) = (gx.floor() as usize, gx - gx.floor());
                let dot = |dy: usize, dx: usize| {
                    let (gxv, gyv) = grads[(cy + dy) * gw + cx + dx];
                    gxv * (fx - dx as f64) + gyv * (fy - dy as f64)
                };
                let tx = fade(fx);
                let top = dot(0, 0) + tx * (dot(0, 1) - dot(0, 0));
                let bottom = dot(1, 0) + tx * (dot(1, 1) - dot(1, 0));
                out[r * cols + c] = SQRT_2 * (top + ty * (bottom - top));
            }
        }
        out
    }

    #[test]
    fn the_octaves_equal_the_per_pixel_reference_bit_for_bit() {
        // Square and not, fewer periods than pixels and more (the surfaces' finest octaves).
        for (rows, cols, base, octaves, persistence) in [
            (64, 64, 2, 6, 0.8),
            (37, 53, 3, 4, 0.6),
            (24, 24, 24, 2, 0.5),
            (1, 5, 1, 3, 0.7),
        ] {
            let (mut a, mut b) = (StdRng::seed_from_u64(7), StdRng::seed_from_u64(7));
            let fast = perlin_octaves(&mut a, rows, cols, base, octaves, persistence);
            let mut slow = vec![0.0; rows * cols];
            let (mut amplitude, mut res) = (1.0, base);
            for _ in 0..octaves {
                let o = reference_octave(&mut b, (rows, cols), (res, res));
                for (s, v) in slow.iter_mut().zip(&o) {
                    *s += amplitude * v;
                }
                amplitude *= persistence;
                res *= 2;
            }
            let differ = fast
                .iter()
                .zip(&slow)
                .filter(|(x, y)| x.to_bits() != y.to_bits());
            assert_eq!(
                differ.count(),
                0,
                "{rows}×{cols}, base {base}, {octaves} octaves"
            );
        }
    }

    #[test]
    fn one_octave_equals_the_reference_bit_for_bit_signs_of_zero_too() {
        // Unequal periods along the axes, a single column or row, a single pixel.
        for (shape, res) in [
            ((37, 53), (3, 5)),
            ((5, 1), (2, 4)),
            ((1, 7), (1, 3)),
            ((1, 1), (1, 1)),
            ((64, 64), (4, 4)),
        ] {
            let (mut a, mut b) = (StdRng::seed_from_u64(3), StdRng::seed_from_u64(3));
            let fast = perlin_octave(&mut a, shape.0, shape.1, res.0, res.1);
            let slow = reference_octave(&mut b, shape, res);
            let differ = fast
                .iter()
                .zip(&slow)
                .filter(|(x, y)| x.to_bits() != y.to_bits());
            assert_eq!(differ.count(), 0, "{shape:?} with {res:?} periods");
        }
    }

    #[test]
    fn octave_is_zero_on_lattice_corners_and_bounded() {
        let mut rng = StdRng::seed_from_u64(1);
        let o = perlin_octave(&mut rng, 64, 64, 4, 4);
        for r in (0..64).step_by(16) {
            for c in (0..64).step_by(16) {
                assert!(o[r * 64 + c].abs() < 1e-12);
            }
        }
        // |noise| ≤ √2 · max corner dot (≤ √2/2·√2 = 1).
        assert!(o.iter().all(|v| v.abs() <= 1.0 + 1e-12));
        assert!(o.iter().any(|v| v.abs() > 0.1));
    }

    #[test]
    fn official_octaves_have_std_about_half_a_cell() {
        // Average over seeds: the first octave has only 3×3 gradients, so one field's std
        // varies a lot; the official figure (≈ 0.5, computed, docs/references.md#foveation) is typical.
        let mut stds = vec![];
        for seed in 0..8 {
            let mut rng = StdRng::seed_from_u64(seed);
            let f = perlin_octaves(&mut rng, 256, 256, 2, 6, 0.8);
            let mean = f.iter().sum::<f64>() / f.len() as f64;
            let var = f.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / f.len() as f64;
            stds.push(var.sqrt());
        }
        let mean_std = stds.iter().sum::<f64>() / stds.len() as f64;
        eprintln!("Perlin std per seed {stds:?}, mean {mean_std:.3}");
        assert!((mean_std - 0.5).abs() < 0.1, "{mean_std}");
    }
}
