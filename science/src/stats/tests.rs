use super::*;

/// `k` Gaussian blobs of `per` points in `dim` dimensions, centres `gap` apart on the axes,
/// spread `sigma`; returns rows and labels.
fn blobs(
    k: usize,
    per: usize,
    dim: usize,
    gap: f64,
    sigma: f64,
    seed: u64,
) -> (Vec<f64>, Vec<usize>) {
    use rand_distr_free::normal;
    let mut rng = SmallRng::seed_from_u64(seed);
    let (mut x, mut labels) = (Vec::new(), Vec::new());
    for c in 0..k {
        for _ in 0..per {
            for d in 0..dim {
                let centre = if d == c % dim { gap } else { 0.0 };
                x.push(centre + sigma * normal(&mut rng));
            }
            labels.push(c);
        }
    }
    (x, labels)
}

mod rand_distr_free {
    use rand::Rng;
    /// A standard normal draw (Box–Muller).
    pub fn normal<R: Rng>(rng: &mut R) -> f64 {
        let u: f64 = rng.random::<f64>().max(1e-300);
        let v: f64 = rng.random();
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
}

#[test]
fn adjusted_rand_index_is_one_for_relabelled_partitions_and_near_zero_for_unrelated() {
    let a = [0, 0, 1, 1, 2, 2];
    assert!((adjusted_rand_index(&a, &[2, 2, 0, 0, 1, 1]) - 1.0).abs() < 1e-12);
    let b = [0, 1, 0, 1, 0, 1];
    assert!(adjusted_rand_index(&a, &b) < 0.1);
}

#[test]
fn kmeans_recovers_separated_blobs_and_not_noise() {
    let (x, truth) = blobs(3, 200, 8, 4.0, 0.5, 1);
    let l = kmeans(&x, 8, 3, 10, 30, 7);
    assert!((adjusted_rand_index(&l, &truth) - 1.0).abs() < 1e-12);
    assert_eq!(matched_recall(&l, &truth, 3), vec![1.0, 1.0, 1.0]);
    // One structureless cloud with random labels: the clusters say nothing about the labels.
    let (x, _) = blobs(1, 600, 8, 0.0, 1.0, 2);
    let mut rng = SmallRng::seed_from_u64(3);
    let random: Vec<usize> = (0..600).map(|_| rng.random_range(0..3)).collect();
    let l = kmeans(&x, 8, 3, 10, 30, 7);
    let ari = adjusted_rand_index(&l, &random);
    assert!(ari.abs() < 0.02, "ARI of unrelated labels {ari}");
}

#[test]
fn kmeans_restarts_escape_a_bad_start() {
    // Two tight pairs of blobs far apart plus a small distant blob: a farthest-point start from
    // row 0 puts two centres on the outlier side; restarts find the partition of least inertia.
    let mut x = Vec::new();
    let mut truth = Vec::new();
    for (c, centre) in [(0, 0.0), (1, 3.0), (2, 40.0)] {
        let n = if c == 2 { 5 } else { 300 };
        for i in 0..n {
            x.push(centre + 0.3 * ((i * 37 % 101) as f64 / 101.0 - 0.5));
            truth.push(c);
        }
    }
    let l = kmeans(&x, 1, 3, 20, 50, 11);
    assert!((adjusted_rand_index(&l, &truth) - 1.0).abs() < 1e-12);
}

#[test]
fn matched_recall_scores_each_class_after_the_best_relabelling() {
    let truth = [0, 0, 0, 0, 1, 1, 1, 1, 2, 2];
    // Clusters relabelled and one item of class 0 misplaced.
    let clusters = [2, 2, 2, 1, 1, 1, 1, 1, 0, 0];
    assert_eq!(matched_recall(&clusters, &truth, 3), vec![0.75, 1.0, 1.0]);
    // Everything in one cluster: one class is found, the others are not.
    let one = [0; 10];
    let r = matched_recall(&one, &truth, 3);
    assert_eq!(r.iter().filter(|&&v| v == 1.0).count(), 1);
    assert_eq!(r.iter().filter(|&&v| v == 0.0).count(), 2);
}

#[test]
fn dprime_and_centroid_recall_have_known_values() {
    // Two 1-D classes: {−1 ± s} and {1 ± s}: means ∓1, variance s², d′ = 2/s.
    let s = 0.25;
    let x = [-1.0 - s, -1.0 + s, 1.0 - s, 1.0 + s];
    let truth = [0, 0, 1, 1];
    for d in dprime_to_nearest(&x, 1, &truth, 2) {
        assert!((d - 2.0 / s).abs() < 1e-12, "{d}");
    }
    assert_eq!(nearest_centroid_recall(&x, 1, &truth, 2), vec![1.0, 1.0]);
    // Identical distributions: d′ near 0 and recall near chance.
    let (x, _) = blobs(1, 2000, 4, 0.0, 1.0, 5);
    let truth: Vec<usize> = (0..2000).map(|i| i % 2).collect();
    for d in dprime_to_nearest(&x, 4, &truth, 2) {
        assert!(d < 0.15, "d′ of identical classes {d}");
    }
    for r in nearest_centroid_recall(&x, 4, &truth, 2) {
        assert!((r - 0.5).abs() < 0.1, "recall of identical classes {r}");
    }
}

#[test]
fn affine_fit_removes_an_affine_map_exactly() {
    let from: Vec<[f64; 2]> = (0..50)
        .map(|i| {
            [
                (i % 7) as f64 * 0.3 - 1.0,
                (i / 7) as f64 * 0.2 - 0.7 + 0.01 * (i as f64).sin(),
            ]
        })
        .collect();
    let to: Vec<[f64; 2]> = from
        .iter()
        .map(|p| [1.3 * p[0] - 0.4 * p[1] + 0.2, 0.5 * p[0] + 0.9 * p[1] - 0.1])
        .collect();
    for (m, t) in fit_affine_2d(&from, &to).iter().zip(&to) {
        assert!((m[0] - t[0]).abs() < 1e-10 && (m[1] - t[1]).abs() < 1e-10);
    }
    // A non-affine target leaves a residual.
    let bent: Vec<[f64; 2]> = from.iter().map(|p| [p[0] * p[0], p[1]]).collect();
    let fit = fit_affine_2d(&from, &bent);
    let residual: f64 = fit
        .iter()
        .zip(&bent)
        .map(|(m, t)| (m[0] - t[0]).abs())
        .sum();
    assert!(residual > 0.1);
}

#[test]
fn matched_recall_works_for_twenty_classes() {
    // 20 classes of 5 items, clusters relabelled by a shuffle; class 0 loses one item to class 1's
    // cluster.
    let k = 20;
    let truth: Vec<usize> = (0..k * 5).map(|i| i / 5).collect();
    let relabel = |t: usize| (t * 7 + 3) % k;
    let mut clusters: Vec<usize> = truth.iter().map(|&t| relabel(t)).collect();
    clusters[0] = relabel(1);
    let r = matched_recall(&clusters, &truth, k);
    assert_eq!(r.len(), k);
    assert_eq!(r[0], 0.8);
    assert!(r[1..].iter().all(|&v| v == 1.0), "{r:?}");
}
