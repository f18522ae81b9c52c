//! Small dense linear algebra used by the colour transforms, CMF-SIM and Neural Scope.
//!
//! Matrices are row-major `&[f64]` with explicit `(rows, cols)`. Least squares goes through a
//! thin SVD (faer) with a relative singular-value cut-off, so rank-deficient problems return the
//! minimum-norm solution instead of blowing up.

use faer::Mat;
use rand::{Rng, RngCore};

/// Relative cut-off below which singular values count as zero in [`lstsq`].
pub const DEFAULT_RCOND: f64 = 1e-12;

/// Result of a least-squares solve.
#[derive(Debug, Clone, PartialEq)]
pub struct Lstsq {
    /// Solution, row-major `(cols × m)`.
    pub x: Vec<f64>,
    /// Numerical rank of `A`.
    pub rank: usize,
    /// Singular values of `A`, descending.
    pub singular_values: Vec<f64>,
}

/// Minimum-norm least-squares solution of `A·X ≈ B`, `A` row-major `(rows × cols)`, `B`
/// row-major `(rows × m)`. Singular values below `rcond · s_max` are treated as zero.
///
/// # Panics
/// If the slice lengths do not match the shapes.
pub fn lstsq(a: &[f64], rows: usize, cols: usize, b: &[f64], m: usize, rcond: f64) -> Lstsq {
    assert_eq!(
        a.len(),
        rows * cols,
        "lstsq: A has {} values, shape {rows}×{cols}",
        a.len()
    );
    assert_eq!(
        b.len(),
        rows * m,
        "lstsq: B has {} values, shape {rows}×{m}",
        b.len()
    );
    if rows == 0 || cols == 0 {
        return Lstsq {
            x: vec![0.0; cols * m],
            rank: 0,
            singular_values: vec![],
        };
    }
    let am = Mat::from_fn(rows, cols, |i, j| a[i * cols + j]);
    let svd = am.thin_svd().expect("SVD converged");
    let (u, v) = (svd.U(), svd.V());
    let s = svd.S().column_vector();
    let size = rows.min(cols);
    let sv: Vec<f64> = (0..size).map(|i| s[i]).collect();
    let smax = sv.iter().copied().fold(0.0, f64::max);
    let cut = rcond * smax;
    let mut x = vec![0.0; cols * m];
    let mut rank = 0;
    let mut coef = vec![0.0; m];
    for k in 0..size {
        if !(sv[k] > cut) || sv[k] == 0.0 {
            continue;
        }
        rank += 1;
        // coef = (u_k · B) / s_k
        coef.fill(0.0);
        for r in 0..rows {
            let ur = u[(r, k)];
            if ur != 0.0 {
                for (c, bv) in coef.iter_mut().zip(&b[r * m..(r + 1) * m]) {
                    *c += ur * bv;
                }
            }
        }
        for c in coef.iter_mut() {
            *c /= sv[k];
        }
        for j in 0..cols {
            let vj = v[(j, k)];
            for (xv, c) in x[j * m..(j + 1) * m].iter_mut().zip(&coef) {
                *xv += vj * c;
            }
        }
    }
    Lstsq {
        x,
        rank,
        singular_values: sv,
    }
}

/// Eigen-decomposition of a symmetric `(n × n)` row-major matrix: the eigenvalues, largest
/// first, and the eigenvectors as the columns of a row-major `(n × n)` matrix in the same order
/// (unit length). Only the lower triangle is read.
///
/// # Panics
/// If `a` does not hold `n²` values, or the decomposition does not converge.
pub fn symmetric_eigen(a: &[f64], n: usize) -> (Vec<f64>, Vec<f64>) {
    assert_eq!(
        a.len(),
        n * n,
        "symmetric_eigen: {} values for shape {n}×{n}",
        a.len()
    );
    let am = Mat::from_fn(n, n, |i, j| a[i * n + j]);
    let evd = am
        .self_adjoint_eigen(faer::Side::Lower)
        .expect("symmetric eigen-decomposition converged");
    let (u, s) = (evd.U(), evd.S().column_vector());
    // faer sorts ascending; reverse to largest first.
    let values = (0..n).rev().map(|k| s[k]).collect();
    let mut vectors = vec![0.0; n * n];
    for (d, k) in (0..n).rev().enumerate() {
        for r in 0..n {
            vectors[r * n + d] = u[(r, k)];
        }
    }
    (values, vectors)
}

/// Column `d` of [`symmetric_eigen`]'s `(n × n)` eigenvectors, signed so that its entry of
/// largest magnitude is positive (an eigenvector's sign is arbitrary; this fixes one).
pub fn signed_eigenvector(vectors: &[f64], n: usize, d: usize) -> Vec<f64> {
    let mut v: Vec<f64> = (0..n).map(|r| vectors[r * n + d]).collect();
    let largest = v
        .iter()
        .copied()
        .fold(0.0, |a: f64, b| if b.abs() > a.abs() { b } else { a });
    if largest < 0.0 {
        v.iter_mut().for_each(|x| *x = -*x);
    }
    v
}

/// `A·v` for a 3×3 matrix.
pub fn mat3_vec(a: &[[f64; 3]; 3], v: [f64; 3]) -> [f64; 3] {
    [
        a[0][0] * v[0] + a[0][1] * v[1] + a[0][2] * v[2],
        a[1][0] * v[0] + a[1][1] * v[1] + a[1][2] * v[2],
        a[2][0] * v[0] + a[2][1] * v[1] + a[2][2] * v[2],
    ]
}

/// `A·B` for 3×3 matrices.
pub fn mat3_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

/// Inverse of a 3×3 matrix, or `None` if it is singular (|det| < 1e-300).
pub fn mat3_inverse(a: &[[f64; 3]; 3]) -> Option<[[f64; 3]; 3]> {
    let c = |i: usize, j: usize| {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
        a[i1][j1] * a[i2][j2] - a[i1][j2] * a[i2][j1]
    };
    let det = a[0][0] * c(0, 0) + a[0][1] * c(0, 1) + a[0][2] * c(0, 2);
    if det.abs() < 1e-300 {
        return None;
    }
    let mut inv = [[0.0; 3]; 3];
    for (i, row) in inv.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = c(j, i) / det;
        }
    }
    Some(inv)
}

/// A random `(rows × cols)` row-major matrix with orthonormal columns (`cols ≤ rows`):
/// Gram–Schmidt on columns of uniform draws in [−1, 1), a draw too close to the span so far
/// redrawn. With `rows == cols` it is a random orthogonal matrix.
///
/// # Panics
/// If `cols > rows`.
pub fn random_orthonormal_columns(rows: usize, cols: usize, rng: &mut dyn RngCore) -> Vec<f64> {
    assert!(
        cols <= rows,
        "random_orthonormal_columns: {cols} columns in {rows} rows"
    );
    let mut columns: Vec<Vec<f64>> = Vec::with_capacity(cols);
    while columns.len() < cols {
        let mut v: Vec<f64> = (0..rows).map(|_| rng.random_range(-1.0..1.0)).collect();
        for c in &columns {
            let d: f64 = v.iter().zip(c).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(c).for_each(|(x, y)| *x -= d * y);
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 1e-3 {
            columns.push(v.into_iter().map(|x| x / norm).collect());
        }
    }
    let mut m = vec![0.0; rows * cols];
    for (j, c) in columns.iter().enumerate() {
        for i in 0..rows {
            m[i * cols + j] = c[i];
        }
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symmetric_eigen_reconstructs_the_matrix_largest_first() {
        // A = V·diag(5, 2, 0.5)·Vᵀ for an orthogonal V: the decomposition returns those values
        // in that order and vectors that rebuild A.
        let mut rng = <rand::rngs::StdRng as rand::SeedableRng>::seed_from_u64(7);
        let v = random_orthonormal_columns(3, 3, &mut rng);
        let lambda = [0.5, 5.0, 2.0];
        let a: Vec<f64> = (0..9)
            .map(|ij| {
                (0..3)
                    .map(|k| v[(ij / 3) * 3 + k] * lambda[k] * v[(ij % 3) * 3 + k])
                    .sum()
            })
            .collect();
        let (values, vectors) = symmetric_eigen(&a, 3);
        for (got, want) in values.iter().zip([5.0, 2.0, 0.5]) {
            assert!((got - want).abs() < 1e-12, "eigenvalues {values:?}");
        }
        for ij in 0..9 {
            let rebuilt: f64 = (0..3)
                .map(|k| vectors[(ij / 3) * 3 + k] * values[k] * vectors[(ij % 3) * 3 + k])
                .sum();
            assert!(
                (rebuilt - a[ij]).abs() < 1e-12,
                "A[{ij}] {} vs {rebuilt}",
                a[ij]
            );
        }
    }

    #[test]
    fn lstsq_solves_square_and_overdetermined_systems() {
        // A = [[2,1],[1,3],[0,1]], x = [[1,-1],[2,0.5]] → B = A·x
        let a = [2.0, 1.0, 1.0, 3.0, 0.0, 1.0];
        let x = [1.0, -1.0, 2.0, 0.5];
        let mut b = vec![0.0; 6];
        for r in 0..3 {
            for c in 0..2 {
                b[r * 2 + c] = (0..2).map(|k| a[r * 2 + k] * x[k * 2 + c]).sum();
            }
        }
        let s = lstsq(&a, 3, 2, &b, 2, DEFAULT_RCOND);
        assert_eq!(s.rank, 2);
        for (g, w) in s.x.iter().zip(&x) {
            assert!((g - w).abs() < 1e-12);
        }
    }

    #[test]
    fn lstsq_rank_deficient_gives_minimum_norm() {
        // two identical columns: x1 + x2 = 2 → minimum norm (1, 1)
        let a = [1.0, 1.0, 1.0, 1.0];
        let b = [2.0, 2.0];
        let s = lstsq(&a, 2, 2, &b, 1, 1e-10);
        assert_eq!(s.rank, 1);
        assert!((s.x[0] - 1.0).abs() < 1e-12 && (s.x[1] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn mat3_inverse_round_trip() {
        let a = [[3.0, 1.0, 0.5], [0.2, 2.0, 0.1], [0.0, 0.3, 1.5]];
        let inv = mat3_inverse(&a).unwrap();
        let id = mat3_mul(&a, &inv);
        for (i, row) in id.iter().enumerate() {
            for (j, v) in row.iter().enumerate() {
                assert!((v - if i == j { 1.0 } else { 0.0 }).abs() < 1e-14);
            }
        }
        assert!(mat3_inverse(&[[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]).is_none());
    }
}
