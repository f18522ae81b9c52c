//! Q's own signal in a set of scenes: the share of Q's variance that L, M and S do not predict.
//!
//! Input: per tile (one scene crop), the sites' true excitations `[L, M, S, Q]` (cone units:
//! ≈ 1 for the sRGB white after the white balance). Two fits of `Q ≈ c₀ + c_L·L + c_M·M + c_S·S`
//! (affine least squares, [`crate::invariants::hidden`]'s), each scored on samples it did not
//! see:
//! - **within**: one fit per tile on its even-numbered sites, scored on its odd-numbered ones;
//!   the share is `Σ residual² / Σ (Q − the tile's scored mean)²` summed over tiles. What a
//!   decoder that knew each scene's own L, M, S → Q relation could not predict: 0 when Q is an
//!   affine function of L, M, S within every tile, even one that changes from tile to tile.
//! - **across**: one fit on the first half of the tiles (every site), scored on the second half:
//!   `Σ residual² / Σ (Q − the scored mean)²`. What one fixed relation, the same in every scene,
//!   leaves: the signal a cortex can learn as Q's own.
//!
//! Beside each share its absolute size, the mean squared residual (cone units²), to set against
//! the eye's noise and demosaicking error ([`super::gates`]). An empty or constant Q has no share
//! (NaN).

use crate::invariants::hidden::affine_residuals;
use serde::{Deserialize, Serialize};

/// Sites of one tile: `[L, M, S, Q]` per site.
pub type TileSites = Vec<[f64; 4]>;

/// Q's own share within and across tiles (module docs).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OwnShare {
    /// Within-tile share (held-out sites).
    pub within: f64,
    /// Across-tile share (held-out tiles).
    pub across: f64,
    /// Mean squared within-tile residual, cone units².
    pub within_residual_var: f64,
    /// Mean squared across-tile residual, cone units².
    pub across_residual_var: f64,
    /// Q's variance over the held-out tiles, cone units².
    pub q_var: f64,
    /// Sites scored across tiles.
    pub sites: usize,
}

/// The within- and across-tile shares of `tiles` (module docs). Needs at least two tiles.
pub fn own_share(tiles: &[TileSites]) -> OwnShare {
    assert!(
        tiles.len() >= 2,
        "own_share: needs at least 2 tiles (fit and score), has {}",
        tiles.len()
    );
    let (mut res_within, mut var_within, mut n_within) = (0.0, 0.0, 0usize);
    for t in tiles {
        let (even, odd): (Vec<_>, Vec<_>) = t.iter().enumerate().partition(|(i, _)| i % 2 == 0);
        let strip =
            |v: Vec<(usize, &[f64; 4])>| -> TileSites { v.into_iter().map(|(_, s)| *s).collect() };
        let (fit, score): (TileSites, TileSites) = (strip(even), strip(odd));
        if fit.len() < 5 || score.is_empty() {
            continue;
        }
        let r = residuals(&fit, &score);
        res_within += r.iter().map(|x| x * x).sum::<f64>();
        var_within += sum_sq_deviation(score.iter().map(|s| s[3]));
        n_within += score.len();
    }
    let half = tiles.len() / 2;
    let fit: TileSites = tiles[..half].concat();
    let score: TileSites = tiles[half..].concat();
    let r = residuals(&fit, &score);
    let res_across = r.iter().map(|x| x * x).sum::<f64>();
    let var_across = sum_sq_deviation(score.iter().map(|s| s[3]));
    let per = |a: f64, n: usize| if n > 0 { a / n as f64 } else { f64::NAN };
    OwnShare {
        within: ratio(res_within, var_within),
        across: ratio(res_across, var_across),
        within_residual_var: per(res_within, n_within),
        across_residual_var: per(res_across, score.len()),
        q_var: per(var_across, score.len()),
        sites: score.len(),
    }
}

/// The affine fit of Q from L, M, S over `sites`: `[c₀, c_L, c_M, c_S]`.
pub fn q_from_lms(sites: &[[f64; 4]]) -> [f64; 4] {
    // The fit's residuals at the unit vectors of L, M, S and at 0 give its coefficients.
    let probes: Vec<[f64; 4]> = vec![
        [0.0, 0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0, 0.0],
        [0.0, 0.0, 1.0, 0.0],
    ];
    let pred: Vec<f64> = residuals(sites, &probes).iter().map(|r| -r).collect();
    [
        pred[0],
        pred[1] - pred[0],
        pred[2] - pred[0],
        pred[3] - pred[0],
    ]
}

/// Residuals `Q − fit(L, M, S)` at `score` of the affine fit on `fit`.
fn residuals(fit: &[[f64; 4]], score: &[[f64; 4]]) -> Vec<f64> {
    let split = |s: &[[f64; 4]]| -> (Vec<f64>, Vec<f64>) {
        (
            s.iter().flat_map(|v| v[..3].to_vec()).collect(),
            s.iter().map(|v| v[3]).collect(),
        )
    };
    let (xf, yf) = split(fit);
    let (xs, ys) = split(score);
    affine_residuals((&xf, &yf), (&xs, &ys), 3)
}

/// `Σ (x − mean)²`.
fn sum_sq_deviation(x: impl Iterator<Item = f64> + Clone) -> f64 {
    let (sum, n) = x.clone().fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        return 0.0;
    }
    let mean = sum / n as f64;
    x.map(|v| (v - mean).powi(2)).sum()
}

/// `a / b`, NaN where `b` is not positive.
fn ratio(a: f64, b: f64) -> f64 {
    if b > 0.0 {
        a / b
    } else {
        f64::NAN
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::SmallRng;
    use rand::{Rng, SeedableRng};

    /// `tiles` tiles of 400 sites with uniform L, M, S and `q(tile, l, m, s, rng)`.
    fn tiles(
        count: usize,
        q: impl Fn(usize, f64, f64, f64, &mut SmallRng) -> f64,
    ) -> Vec<TileSites> {
        let mut rng = SmallRng::seed_from_u64(7);
        (0..count)
            .map(|t| {
                (0..400)
                    .map(|_| {
                        let (l, m, s) = (rng.random(), rng.random(), rng.random());
                        [l, m, s, q(t, l, m, s, &mut rng)]
                    })
                    .collect()
            })
            .collect()
    }

    #[test]
    fn a_fixed_affine_q_has_no_share() {
        let t = tiles(8, |_, l, m, s, _| 0.2 + 0.7 * l - 0.3 * m + 0.1 * s);
        let o = own_share(&t);
        assert!(o.within < 1e-20 && o.across < 1e-20, "{o:?}");
        let c = q_from_lms(&t.concat());
        for (got, want) in c.iter().zip([0.2, 0.7, -0.3, 0.1]) {
            assert!((got - want).abs() < 1e-9, "{c:?}");
        }
    }

    #[test]
    fn an_independent_q_is_all_its_own() {
        let t = tiles(8, |_, _, _, _, rng| rng.random());
        let o = own_share(&t);
        assert!(o.within > 0.95 && o.across > 0.98, "{o:?}");
        // Uniform on [0, 1]: variance 1/12.
        assert!((o.across_residual_var - 1.0 / 12.0).abs() < 0.01, "{o:?}");
    }

    #[test]
    fn added_noise_is_its_own_share_of_the_variance() {
        // Q = L + 0.5·(u − ½), u uniform: noise variance 0.25/12 beside var(L) = 1/12, so the
        // share is 0.25 / 1.25 = 0.2 within and across tiles.
        let t = tiles(8, |_, l, _, _, rng| l + 0.5 * (rng.random::<f64>() - 0.5));
        let noise_var = 0.25 / 12.0;
        let o = own_share(&t);
        assert!((o.across - 0.2).abs() < 0.02, "{o:?}");
        assert!((o.within - 0.2).abs() < 0.03, "{o:?}");
        assert!(
            (o.across_residual_var - noise_var).abs() < 0.1 * noise_var,
            "{o:?}"
        );
    }

    #[test]
    fn a_relation_that_changes_between_tiles_is_own_across_but_not_within() {
        let t = tiles(8, |tile, l, m, _, _| if tile % 2 == 0 { l } else { m });
        let o = own_share(&t);
        assert!(o.within < 1e-20, "{o:?}");
        assert!(o.across > 0.3, "{o:?}");
    }
}
