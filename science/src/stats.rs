//! Statistics the evaluation uses: k-means with restarts, the adjusted Rand index, matching
//! clusters to labels, separability (d′), Pearson correlation and a 2-D affine least-squares
//! fit. Rows are `(m, dim)` row-major `f64`; labels are `0..k`.

pub mod assignment;

use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// Pearson correlation (NaN when either side is constant).
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    colorimetry::stiles_burch::correlation(a, b)
}

fn squared_distance(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).powi(2)).sum()
}

/// k-means++ seeding (Arthur & Vassilvitskii 2007) from `rng`.
fn seed_centres(x: &[f64], dim: usize, k: usize, rng: &mut SmallRng) -> Vec<Vec<f64>> {
    let m = x.len() / dim;
    let row = |i: usize| &x[i * dim..(i + 1) * dim];
    let mut centres = vec![row(rng.random_range(0..m)).to_vec()];
    let mut nearest: Vec<f64> = (0..m)
        .map(|i| squared_distance(row(i), &centres[0]))
        .collect();
    while centres.len() < k.min(m) {
        let total: f64 = nearest.iter().sum();
        let pick = if total > 0.0 {
            let mut t = rng.random::<f64>() * total;
            nearest
                .iter()
                .position(|&d| {
                    t -= d;
                    t <= 0.0
                })
                .unwrap_or(m - 1)
        } else {
            rng.random_range(0..m)
        };
        centres.push(row(pick).to_vec());
        let c = centres.last().expect("just pushed");
        for (i, n) in nearest.iter_mut().enumerate() {
            *n = n.min(squared_distance(row(i), c));
        }
    }
    centres
}

/// Lloyd iterations from `centres`; returns labels and inertia (sum of squared distances).
fn lloyd(x: &[f64], dim: usize, centres: &mut [Vec<f64>], iterations: usize) -> (Vec<usize>, f64) {
    let m = x.len() / dim;
    let row = |i: usize| &x[i * dim..(i + 1) * dim];
    let mut labels = vec![0; m];
    let mut inertia = f64::INFINITY;
    for _ in 0..iterations.max(1) {
        inertia = 0.0;
        for (i, l) in labels.iter_mut().enumerate() {
            let (best, d) = (0..centres.len())
                .map(|c| (c, squared_distance(row(i), &centres[c])))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .expect("k ≥ 1");
            *l = best;
            inertia += d;
        }
        let mut sums = vec![vec![0.0; dim]; centres.len()];
        let mut counts = vec![0usize; centres.len()];
        for (i, &l) in labels.iter().enumerate() {
            counts[l] += 1;
            for (s, v) in sums[l].iter_mut().zip(row(i)) {
                *s += v;
            }
        }
        for (c, centre) in centres.iter_mut().enumerate() {
            if counts[c] > 0 {
                for (v, s) in centre.iter_mut().zip(&sums[c]) {
                    *v = s / counts[c] as f64;
                }
            }
        }
    }
    (labels, inertia)
}

/// k-means on `(m, dim)` rows: `restarts` k-means++ seedings (deterministic from `seed`), each
/// refined by `iterations` Lloyd steps; the labelling of least inertia.
pub fn kmeans(
    x: &[f64],
    dim: usize,
    k: usize,
    restarts: usize,
    iterations: usize,
    seed: u64,
) -> Vec<usize> {
    assert!(
        dim > 0 && !x.is_empty() && x.len().is_multiple_of(dim) && k > 0,
        "kmeans: {} values do not make rows of {dim} (k = {k})",
        x.len()
    );
    let mut rng = SmallRng::seed_from_u64(seed);
    let mut best: Option<(Vec<usize>, f64)> = None;
    for _ in 0..restarts.max(1) {
        let mut centres = seed_centres(x, dim, k, &mut rng);
        let (labels, inertia) = lloyd(x, dim, &mut centres, iterations);
        if best.as_ref().is_none_or(|b| inertia < b.1) {
            best = Some((labels, inertia));
        }
    }
    best.expect("at least one restart").0
}

/// Adjusted Rand index of two labelings (Hubert & Arabie 1985): 1 = identical partitions,
/// ≈ 0 = chance.
pub fn adjusted_rand_index(a: &[usize], b: &[usize]) -> f64 {
    assert_eq!(
        a.len(),
        b.len(),
        "adjusted_rand_index: {} vs {} labels",
        a.len(),
        b.len()
    );
    let (ka, kb) = (
        a.iter().max().map_or(0, |m| m + 1),
        b.iter().max().map_or(0, |m| m + 1),
    );
    let mut table = vec![0f64; ka * kb];
    for (&i, &j) in a.iter().zip(b) {
        table[i * kb + j] += 1.0;
    }
    let c2 = |x: f64| x * (x - 1.0) / 2.0;
    let sum_ij: f64 = table.iter().map(|&v| c2(v)).sum();
    let sum_a: f64 = (0..ka)
        .map(|i| c2((0..kb).map(|j| table[i * kb + j]).sum()))
        .sum();
    let sum_b: f64 = (0..kb)
        .map(|j| c2((0..ka).map(|i| table[i * kb + j]).sum()))
        .sum();
    let total = c2(a.len() as f64);
    let expected = sum_a * sum_b / total.max(1.0);
    let max = 0.5 * (sum_a + sum_b);
    if (max - expected).abs() < 1e-12 {
        return 1.0;
    }
    (sum_ij - expected) / (max - expected)
}

/// Per-class recall of `clusters` after matching each true class to one cluster so that the
/// number of agreeing items is largest (the Hungarian algorithm, [`assignment`]; any number of
/// classes). Classes without members get NaN.
pub fn matched_recall(clusters: &[usize], truth: &[usize], k: usize) -> Vec<f64> {
    let kc = clusters.iter().max().map_or(0, |m| m + 1).max(k);
    let mut table = vec![0usize; k * kc];
    for (&c, &t) in clusters.iter().zip(truth) {
        table[t * kc + c] += 1;
    }
    let best = assignment::max_weight_assignment(&table, k, kc);
    (0..k)
        .map(|t| {
            let members: usize = table[t * kc..(t + 1) * kc].iter().sum();
            table[t * kc + best[t]] as f64 / members as f64
        })
        .collect()
}

/// Mean and variance of each labelled group's rows; `None` for empty groups.
fn group_moments(x: &[f64], dim: usize, labels: &[usize], k: usize) -> Vec<Option<Vec<f64>>> {
    (0..k)
        .map(|g| {
            let rows: Vec<&[f64]> = labels
                .iter()
                .enumerate()
                .filter(|&(_, &l)| l == g)
                .map(|(i, _)| &x[i * dim..(i + 1) * dim])
                .collect();
            (!rows.is_empty()).then(|| {
                (0..dim)
                    .map(|d| rows.iter().map(|r| r[d]).sum::<f64>() / rows.len() as f64)
                    .collect()
            })
        })
        .collect()
}

/// Per-class recall of the nearest true-class centroid (each class's centroid from its own
/// members, the item itself included): how many of a class sit closer to their own class's
/// centre than to any other. NaN for classes without members.
pub fn nearest_centroid_recall(x: &[f64], dim: usize, truth: &[usize], k: usize) -> Vec<f64> {
    let centres = group_moments(x, dim, truth, k);
    let mut hits = vec![0usize; k];
    let mut counts = vec![0usize; k];
    for (i, &t) in truth.iter().enumerate() {
        let row = &x[i * dim..(i + 1) * dim];
        counts[t] += 1;
        let nearest = (0..k)
            .filter_map(|c| centres[c].as_ref().map(|m| (c, squared_distance(row, m))))
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(c, _)| c);
        hits[t] += usize::from(nearest == Some(t));
    }
    (0..k).map(|c| hits[c] as f64 / counts[c] as f64).collect()
}

/// For each class, d′ against its nearest other class along the line joining their centroids:
/// `|μ_a − μ_b| / sqrt((σ_a² + σ_b²)/2)`, σ² the variance of the projections. 3 separates two
/// Gaussian classes with about 7 % overlap, 0 is no separation. NaN for classes without
/// members or when there is one class.
pub fn dprime_to_nearest(x: &[f64], dim: usize, truth: &[usize], k: usize) -> Vec<f64> {
    let centres = group_moments(x, dim, truth, k);
    let projected_var = |g: usize, unit: &[f64], mean: f64| -> f64 {
        let (mut s, mut n) = (0.0, 0usize);
        for (i, _) in truth.iter().enumerate().filter(|&(_, &l)| l == g) {
            let p: f64 = x[i * dim..(i + 1) * dim]
                .iter()
                .zip(unit)
                .map(|(a, u)| a * u)
                .sum();
            s += (p - mean).powi(2);
            n += 1;
        }
        s / n.max(1) as f64
    };
    (0..k)
        .map(|a| {
            let Some(ma) = &centres[a] else {
                return f64::NAN;
            };
            let nearest = (0..k)
                .filter(|&b| b != a)
                .filter_map(|b| centres[b].as_ref().map(|mb| (b, squared_distance(ma, mb))))
                .min_by(|p, q| p.1.total_cmp(&q.1));
            let Some((b, d2)) = nearest else {
                return f64::NAN;
            };
            let mb = centres[b].as_ref().expect("filtered");
            let gap = d2.sqrt();
            if gap == 0.0 {
                return 0.0;
            }
            let unit: Vec<f64> = ma.iter().zip(mb).map(|(p, q)| (p - q) / gap).collect();
            let dot = |m: &[f64]| m.iter().zip(&unit).map(|(v, u)| v * u).sum::<f64>();
            let pooled =
                0.5 * (projected_var(a, &unit, dot(ma)) + projected_var(b, &unit, dot(mb)));
            gap / pooled.sqrt().max(1e-300)
        })
        .collect()
}

/// Least-squares affine map `to ≈ A·from + b` of 2-D points; returns the mapped `from`.
pub fn fit_affine_2d(from: &[[f64; 2]], to: &[[f64; 2]]) -> Vec<[f64; 2]> {
    assert_eq!(
        from.len(),
        to.len(),
        "fit_affine_2d: {} vs {} points",
        from.len(),
        to.len()
    );
    // Normal equations of [x y 1] → each output coordinate (3×3, solved by Cramer's rule).
    let mut g = [[0.0f64; 3]; 3];
    let mut rhs = [[0.0f64; 3]; 2];
    for (p, q) in from.iter().zip(to) {
        let v = [p[0], p[1], 1.0];
        for r in 0..3 {
            for c in 0..3 {
                g[r][c] += v[r] * v[c];
            }
            rhs[0][r] += v[r] * q[0];
            rhs[1][r] += v[r] * q[1];
        }
    }
    let det3 = |m: &[[f64; 3]; 3]| {
        m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
            - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
            + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
    };
    let det = det3(&g);
    let solve = |b: &[f64; 3]| -> [f64; 3] {
        let mut out = [0.0; 3];
        for (c, o) in out.iter_mut().enumerate() {
            let mut m = g;
            for r in 0..3 {
                m[r][c] = b[r];
            }
            *o = if det.abs() > 1e-300 {
                det3(&m) / det
            } else {
                0.0
            };
        }
        out
    };
    let (cx, cy) = (solve(&rhs[0]), solve(&rhs[1]));
    from.iter()
        .map(|p| {
            [
                cx[0] * p[0] + cx[1] * p[1] + cx[2],
                cy[0] * p[0] + cy[1] * p[1] + cy[2],
            ]
        })
        .collect()
}

#[cfg(test)]
mod tests;
