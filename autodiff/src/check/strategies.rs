//! Proptest strategies for gradient checks: shapes with 1..=6 per axis, values in [-2, 2].

use crate::Tensor;
use proptest::prelude::*;

/// Proptest settings for op checks: few cases, each a full gradient check.
pub fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 24,
        ..ProptestConfig::default()
    }
}

/// Axis lengths in 1..=6 for the given rank.
pub fn dims(rank: usize) -> impl Strategy<Value = Vec<usize>> {
    proptest::collection::vec(1usize..=6, rank)
}

/// A tensor of `dims` with values uniform in [-2, 2].
pub fn tensor_of(dims: Vec<usize>) -> impl Strategy<Value = Tensor<f64>> {
    let n: usize = dims.iter().product();
    proptest::collection::vec(-2.0f64..2.0, n).prop_map(move |v| Tensor::from_vec(&dims[..], v))
}

/// A tensor of random shape of `rank`, values in [-2, 2].
pub fn tensor(rank: usize) -> impl Strategy<Value = Tensor<f64>> {
    dims(rank).prop_flat_map(tensor_of)
}

/// Values in `[lo, hi]` at least `margin` away from `kink` (for relu/abs at 0).
pub fn away_from(lo: f64, hi: f64, kink: f64, margin: f64) -> impl Strategy<Value = f64> {
    (lo..hi).prop_map(move |v| {
        if (v - kink).abs() < margin {
            kink + margin.copysign(v - kink)
        } else {
            v
        }
    })
}

/// A tensor of `dims` with values in [-2, 2] at least `margin` away from `kink`.
pub fn tensor_away_from(
    dims: Vec<usize>,
    kink: f64,
    margin: f64,
) -> impl Strategy<Value = Tensor<f64>> {
    let n: usize = dims.iter().product();
    proptest::collection::vec(away_from(-2.0, 2.0, kink, margin), n)
        .prop_map(move |v| Tensor::from_vec(&dims[..], v))
}
