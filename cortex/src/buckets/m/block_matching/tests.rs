//! Block matching against the official search and against scalar references.

use super::*;
use crate::buckets::m::IdentityFlow;
use crate::data::DataSource;
use crate::synthetic::{SyntheticConfig, SyntheticSource};

fn matcher() -> BlockMatcher {
    BlockMatcher::from_config(&crate::CortexConfig::quick().m)
}

/// A smooth non-linear map (not a flow, its inverse is exact only to Newton precision, but
/// that is all a grid needs) whose central spacing gives a 128² grid at n = 64.
struct Bulge;

impl PlainFlow for Bulge {
    fn forward(&self, p: &mut [[f64; 2]]) {
        for q in p {
            *q = [q[0] * (1.0 + 0.05 * q[0] * q[0]), q[1] + 0.04 * q[0]];
        }
    }
    fn inverse(&self, p: &mut [[f64; 2]]) {
        for q in p {
            let mut x = q[0];
            for _ in 0..30 {
                x -= (x * (1.0 + 0.05 * x * x) - q[0]) / (1.0 + 0.15 * x * x);
            }
            *q = [x, q[1] - 0.04 * x];
        }
    }
}

/// The scalar score the vectorised one replaced: one running sum per row.
fn score_reference(a: &[f32], ma: &[f32], b: &[f32], mb: &[f32], side: usize, s: [i64; 2]) -> f64 {
    let n = side as i64;
    let (y0, y1) = ((-s[1]).max(0), (n - s[1]).min(n));
    let (x0, x1) = ((-s[0]).max(0), (n - s[0]).min(n));
    if y0 >= y1 || x0 >= x1 {
        return f64::INFINITY;
    }
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for y in y0..y1 {
        let (mut nr, mut dr) = (0.0f32, 0.0f32);
        for x in x0..x1 {
            let (ia, ib) = (((y + s[1]) * n + x + s[0]) as usize, (y * n + x) as usize);
            let m = ma[ia] * mb[ib];
            nr += m * (a[ia] - b[ib]).abs();
            dr += m;
        }
        num += nr as f64;
        den += dr as f64;
    }
    if den > 0.0 {
        num / den
    } else {
        f64::INFINITY
    }
}

/// The per-pixel reference of the search: `DewarpGrid::sample` per frame, average/max
/// pooling, the reference score.
fn estimate_reference(
    m: &BlockMatcher,
    b1: &[f32],
    b2: &[f32],
    n: usize,
    g: &DewarpGrid,
) -> Vec<[i32; 2]> {
    let (nn, side) = (n * n, g.side);
    let levels = (side.trailing_zeros() - m.coarsest_level_px.trailing_zeros()) as usize;
    let pool = |img: &[f32], s: usize, max: bool| -> Vec<f32> {
        let h = s / 2;
        let mut out = vec![0.0; h * h];
        for y in 0..h {
            for x in 0..h {
                let v = [
                    img[2 * y * s + 2 * x],
                    img[2 * y * s + 2 * x + 1],
                    img[(2 * y + 1) * s + 2 * x],
                    img[(2 * y + 1) * s + 2 * x + 1],
                ];
                out[y * h + x] = if max {
                    v.iter().copied().fold(0.0, f32::max)
                } else {
                    v.iter().sum::<f32>() * 0.25
                };
            }
        }
        out
    };
    (0..b1.len() / nn)
        .map(|b| {
            let mut im = [vec![0.0; side * side], vec![0.0; side * side]];
            let mut mk = [vec![0.0; side * side], vec![0.0; side * side]];
            g.sample(&b1[b * nn..(b + 1) * nn], n, &mut im[0], &mut mk[0]);
            g.sample(&b2[b * nn..(b + 1) * nn], n, &mut im[1], &mut mk[1]);
            let mut pyr = vec![(im, mk)];
            for l in 0..levels {
                let (im, mk) = &pyr[l];
                let s = side >> l;
                let next = (
                    [pool(&im[0], s, false), pool(&im[1], s, false)],
                    [pool(&mk[0], s, true), pool(&mk[1], s, true)],
                );
                pyr.push(next);
            }
            let mut acc = [0i64; 2];
            for l in (0..=levels).rev() {
                if l != levels {
                    acc = [acc[0] * 2, acc[1] * 2];
                }
                let (im, mk) = &pyr[l];
                let min_count =
                    m.min_overlap_fraction * mk[1].iter().map(|&v| v as f64).sum::<f64>();
                let mut best = (f64::INFINITY, acc);
                for dy in -2..=2 {
                    for dx in -2..=2 {
                        let c = [acc[0] + dx, acc[1] + dy];
                        let mut sc = score_reference(&im[0], &mk[0], &im[1], &mk[1], side >> l, c);
                        let den = {
                            // the overlap's valid count, as `score` checks it
                            let mut d = 0.0;
                            let s = (side >> l) as i64;
                            for y in (-c[1]).max(0)..(s - c[1]).min(s) {
                                for x in (-c[0]).max(0)..(s - c[0]).min(s) {
                                    d += (mk[0][((y + c[1]) * s + x + c[0]) as usize]
                                        * mk[1][(y * s + x) as usize])
                                        as f64;
                                }
                            }
                            d
                        };
                        if den < min_count {
                            sc = f64::INFINITY;
                        }
                        if sc < best.0 {
                            best = (sc, c);
                        }
                    }
                }
                acc = best.1;
            }
            [acc[0] as i32, acc[1] as i32]
        })
        .collect()
}

/// The vectorised score equals the one-sum-per-row score to f32 rounding, for widths with
/// and without a tail and shifts with partial overlap.
#[test]
fn score_matches_scalar_reference() {
    let mut rng = crate::rng::CortexRng::seed_from(21);
    for side in [4usize, 8, 19, 64] {
        let img = |rng: &mut crate::rng::CortexRng| -> Vec<f32> {
            (0..side * side).map(|_| rng.normal() as f32).collect()
        };
        let (a, b) = (img(&mut rng), img(&mut rng));
        let ma: Vec<f32> = (0..side * side)
            .map(|_| if rng.uniform() < 0.8 { 1.0 } else { 0.0 })
            .collect();
        let mb: Vec<f32> = (0..side * side)
            .map(|_| if rng.uniform() < 0.8 { 1.0 } else { 0.0 })
            .collect();
        for s in [[0i64, 0], [3, -1], [-2, 2], [1, 5], [side as i64, 0]] {
            let got = score(&a, &ma, &b, &mb, side, s, 0.0);
            let want = score_reference(&a, &ma, &b, &mb, side, s);
            if want.is_infinite() {
                assert!(got.is_infinite(), "side {side}, shift {s:?}: {got}");
            } else {
                assert!(
                    (got - want).abs() <= 1e-5 * want.abs(),
                    "side {side}, shift {s:?}: {got} vs {want}"
                );
            }
        }
    }
}

/// The search with taps and masks shared across frames and samples finds the same shifts
/// as the per-frame reference, on a non-trivial 128² de-warping grid and on the identity.
#[test]
fn shared_taps_search_matches_reference() {
    let n = 64;
    let mut src = SyntheticSource::new(SyntheticConfig::lms(n, 5));
    let batch = src.next_batch(12);
    let (mut f0, mut f1) = (Vec::new(), Vec::new());
    batch.frames(0, &mut f0);
    batch.frames(1, &mut f1);
    let m = matcher();
    let (b1, b2) = (m.blur(&f0, n), m.blur(&f1, n));
    for g in [
        DewarpGrid::new(&Bulge, n, 128),
        DewarpGrid::new(&IdentityFlow, n, 128),
    ] {
        let got = m.estimate_blurred(&b1, &b2, n, &g);
        let want = estimate_reference(&m, &b1, &b2, n, &g);
        assert_eq!(got.shift_px, want, "side {}", g.side);
    }
    assert_eq!(DewarpGrid::new(&Bulge, n, 128).side, 128);
}

#[test]
fn identity_grid_is_the_ons_grid() {
    let g = DewarpGrid::new(&IdentityFlow, 64, 128);
    assert_eq!(g.side, 64);
    let want = crate::buckets::m::sampling::unit_grid(64);
    for (a, b) in g.uv.iter().zip(&want) {
        assert!((a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12);
    }
}

/// Random integer shifts in [−15, 14] on noise-free ONS (identity P)
/// are recovered in ≥ 95 % of trials.
#[test]
fn block_matching_recovers_integer_shifts() {
    let n = 64;
    let mut src = SyntheticSource::new(SyntheticConfig::lms(n, 11));
    let trials = 200;
    let batch = src.next_batch(trials);
    let (mut f0, mut f1) = (Vec::new(), Vec::new());
    batch.frames(0, &mut f0);
    batch.frames(1, &mut f1);
    let est = matcher().estimate(&f0, &f1, n, &IdentityFlow);
    let hits = est
        .shift_px
        .iter()
        .zip(&src.last_shifts)
        .filter(|(a, b)| a == b)
        .count();
    println!("block matching recovered {hits} of {trials} shifts");
    assert!(hits * 100 >= 95 * trials, "recovered {hits} of {trials}");
    // field units: one pixel is 2/(n−1) at identity P
    for (d, s) in est.motion.iter().zip(&est.shift_px) {
        assert!(
            (d[0] * 31.5 - s[0] as f64).abs() < 1e-9 && (d[1] * 31.5 - s[1] as f64).abs() < 1e-9
        );
    }
}
