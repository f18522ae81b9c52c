//! Where two cortices' weights lead: how alike their percepts of the same held-out frames are,
//! by measures that survive the network's symmetries (a learning rule's run against backprop's).
//!
//! The cosine of a rule's update to backprop's gradient (`cortex.train.alignment_every_steps`)
//! compares two directions at the same weights; it says nothing of where the weights went (a
//! sign-flipped feedback keeps positive cosines while its percept loses colour). Two cortices
//! that decode alike may differ by any invertible map of their percept channels, so:
//! - **affine R²** ([`affine_r2`]): an affine least-squares map from percept A's channels to
//!   percept B's, fitted on the first half of the held-out pixels, and the fraction of B's
//!   variance (summed over its channels) it explains on the second half. 1: B is an affine
//!   function of A; 0: no better than B's mean; negative: worse. Not symmetric: A → B asks
//!   whether A carries everything B does.
//! - **linear CKA** ([`linear_cka`], Kornblith et al. 2019, "Similarity of neural network
//!   representations revisited", ICML): `‖YᵀX‖²_F / (‖XᵀX‖_F ‖YᵀY‖_F)` on column-centred
//!   `X (samples × a)`, `Y (samples × b)`; invariant to orthogonal maps and isotropic scaling,
//!   1 for identical representations, 0 for orthogonal ones.
//!
//! Samples are the pixels of the percept `(B, N, n, n)` at least the loss border from every
//! edge, every frame.
//! Evaluation only: nothing here feeds learning.

use colorimetry::linalg::{lstsq, DEFAULT_RCOND};
use cortex::Cortex;
use serde::{Deserialize, Serialize};

/// Two cortices' percepts of the same frames compared (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct PerceptAlignment {
    /// Held-out R² of B's percept from A's (affine).
    pub r2_b_from_a: f64,
    /// Held-out R² of A's percept from B's (affine).
    pub r2_a_from_b: f64,
    /// Linear CKA of the two percepts.
    pub cka: f64,
    /// Pixels compared.
    pub samples: usize,
}

/// Rows `(pixels, N)` of a percept `(B, N, n, n)`: the pixels at least `border_px` from every
/// edge.
pub fn percept_rows(
    percept: &[f32],
    batch: usize,
    dim: usize,
    n: usize,
    border_px: usize,
) -> Vec<f64> {
    assert_eq!(
        percept.len(),
        batch * dim * n * n,
        "percept_rows: (B, N, n, n)"
    );
    let inner = border_px..n.saturating_sub(border_px);
    let mut rows = Vec::with_capacity(batch * n * n * dim);
    for b in 0..batch {
        for y in inner.clone() {
            for x in inner.clone() {
                rows.extend((0..dim).map(|c| percept[((b * dim + c) * n + y) * n + x] as f64));
            }
        }
    }
    rows
}

/// Column-centred copy of row-major `(rows × cols)`.
fn centred(x: &[f64], cols: usize) -> Vec<f64> {
    let rows = x.len() / cols.max(1);
    let mut mean = vec![0.0; cols];
    for r in x.chunks(cols) {
        mean.iter_mut()
            .zip(r)
            .for_each(|(m, v)| *m += v / rows as f64);
    }
    x.chunks(cols)
        .flat_map(|r| r.iter().zip(&mean).map(|(v, m)| v - m).collect::<Vec<_>>())
        .collect()
}

/// `AᵀB` of row-major `A (rows × a)`, `B (rows × b)`, row-major `(a × b)`.
fn cross(a: &[f64], ca: usize, b: &[f64], cb: usize) -> Vec<f64> {
    let mut out = vec![0.0; ca * cb];
    for (ra, rb) in a.chunks(ca).zip(b.chunks(cb)) {
        for (i, &va) in ra.iter().enumerate() {
            for (j, &vb) in rb.iter().enumerate() {
                out[i * cb + j] += va * vb;
            }
        }
    }
    out
}

fn frobenius_sq(m: &[f64]) -> f64 {
    m.iter().map(|v| v * v).sum()
}

/// Linear CKA of `x (rows × cx)` and `y (rows × cy)`, row-major (module docs); NaN when either
/// is constant.
pub fn linear_cka(x: &[f64], cx: usize, y: &[f64], cy: usize) -> f64 {
    assert_eq!(x.len() / cx, y.len() / cy, "linear_cka: the same rows");
    let (x, y) = (centred(x, cx), centred(y, cy));
    let xy = frobenius_sq(&cross(&y, cy, &x, cx));
    let xx = frobenius_sq(&cross(&x, cx, &x, cx)).sqrt();
    let yy = frobenius_sq(&cross(&y, cy, &y, cy)).sqrt();
    if xx == 0.0 || yy == 0.0 {
        return f64::NAN;
    }
    xy / (xx * yy)
}

/// Held-out R² of an affine map from `from (rows × cf)` to `to (rows × ct)`: fitted on the
/// first half of the rows, scored on the second (module docs); NaN when `to` is constant on
/// the second half (no variance to explain).
pub fn affine_r2(from: &[f64], cf: usize, to: &[f64], ct: usize) -> f64 {
    let rows = from.len() / cf;
    assert_eq!(rows, to.len() / ct, "affine_r2: the same rows");
    let half = rows / 2;
    let design = |r: std::ops::Range<usize>| -> Vec<f64> {
        r.flat_map(|i| {
            let mut row = from[i * cf..(i + 1) * cf].to_vec();
            row.push(1.0);
            row
        })
        .collect()
    };
    let fit = lstsq(
        &design(0..half),
        half,
        cf + 1,
        &to[..half * ct],
        ct,
        DEFAULT_RCOND,
    )
    .x;
    let test = design(half..rows);
    let truth = &to[half * ct..];
    let mut mean = vec![0.0; ct];
    for r in truth.chunks(ct) {
        mean.iter_mut()
            .zip(r)
            .for_each(|(m, v)| *m += v / (rows - half) as f64);
    }
    let (mut sse, mut sst) = (0.0, 0.0);
    for (d, t) in test.chunks(cf + 1).zip(truth.chunks(ct)) {
        for j in 0..ct {
            let p: f64 = (0..=cf).map(|i| d[i] * fit[i * ct + j]).sum();
            sse += (t[j] - p).powi(2);
            sst += (t[j] - mean[j]).powi(2);
        }
    }
    if sst == 0.0 {
        return f64::NAN;
    }
    1.0 - sse / sst
}

/// The percepts of cortices `a` and `b` of the same frames `ons (batch, n, n)` compared at the
/// pixels at least `border_px` from every edge.
pub fn compare(
    a: &Cortex,
    b: &Cortex,
    ons: &[f32],
    batch: usize,
    border_px: usize,
) -> PerceptAlignment {
    let n = a.n();
    assert_eq!(n, b.n(), "compare: cortices of one eye");
    let rows = |c: &Cortex| {
        let dim = c.config.percept_dim();
        (
            percept_rows(&c.decode_frames(ons, batch), batch, dim, n, border_px),
            dim,
        )
    };
    let ((xa, da), (xb, db)) = (rows(a), rows(b));
    PerceptAlignment {
        r2_b_from_a: affine_r2(&xa, da, &xb, db),
        r2_a_from_b: affine_r2(&xb, db, &xa, da),
        cka: linear_cka(&xa, da, &xb, db),
        samples: xa.len() / da,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random(rows: usize, cols: usize, seed: u64) -> Vec<f64> {
        let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
        (0..rows * cols)
            .map(|_| rng.random::<f64>() - 0.5)
            .collect()
    }

    /// `x (rows × cx)` times `m (cx × cy)` plus `offset`.
    fn mapped(x: &[f64], cx: usize, m: &[f64], cy: usize, offset: f64) -> Vec<f64> {
        x.chunks(cx)
            .flat_map(|r| {
                (0..cy).map(move |j| offset + (0..cx).map(|i| r[i] * m[i * cy + j]).sum::<f64>())
            })
            .collect()
    }

    #[test]
    fn an_invertible_map_of_a_percept_is_fully_aligned_and_an_unrelated_one_is_not() {
        let x = random(2000, 3, 1);
        let m = [2.0, -1.0, 0.5, 0.3, 1.5, -0.7, 0.1, 0.2, 3.0];
        let y = mapped(&x, 3, &m, 3, 4.0);
        assert!((affine_r2(&x, 3, &y, 3) - 1.0).abs() < 1e-9);
        assert!((affine_r2(&y, 3, &x, 3) - 1.0).abs() < 1e-9);
        // An orthogonal map and a scale leave CKA at 1.
        let rot = [0.0, -2.0, 0.0, 2.0, 0.0, 0.0, 0.0, 0.0, 2.0];
        let z = mapped(&x, 3, &rot, 3, -1.0);
        assert!((linear_cka(&x, 3, &z, 3) - 1.0).abs() < 1e-9);
        // Independent noise: R² about 0 (held out: at most slightly positive), CKA small.
        let w = random(2000, 3, 2);
        assert!(
            affine_r2(&x, 3, &w, 3) < 0.02,
            "{}",
            affine_r2(&x, 3, &w, 3)
        );
        assert!(
            linear_cka(&x, 3, &w, 3) < 0.02,
            "{}",
            linear_cka(&x, 3, &w, 3)
        );
    }

    #[test]
    fn a_percept_that_drops_a_channel_explains_less_than_it_is_explained() {
        // B keeps two of A's three channels: A → B is exact, B → A misses a third of A.
        let a = random(3000, 3, 3);
        let b: Vec<f64> = a.chunks(3).flat_map(|r| [r[0], r[1]]).collect();
        assert!((affine_r2(&a, 3, &b, 2) - 1.0).abs() < 1e-9);
        let back = affine_r2(&b, 2, &a, 3);
        assert!((back - 2.0 / 3.0).abs() < 0.03, "{back}");
    }

    #[test]
    fn rows_keep_the_pixels_inside_the_border_channel_by_channel() {
        // (B 1, N 2, 4 × 4), border 1: the 2 × 2 centre, channels side by side.
        let p: Vec<f32> = (0..32).map(|i| i as f32).collect();
        let rows = percept_rows(&p, 1, 2, 4, 1);
        assert_eq!(rows, vec![5.0, 21.0, 6.0, 22.0, 9.0, 25.0, 10.0, 26.0]);
    }
}
