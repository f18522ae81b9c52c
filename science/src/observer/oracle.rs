//! Oracle decoders: percepts built from the true eye, whose colour dimension is known. They
//! calibrate CMF-SIM (the known-answer rungs of its ladder); they are never trained and never
//! used by the cortex.
//!
//! Decoding one ONS frame `(n, n)`:
//! 1. **Invert lateral inhibition exactly** ([`retina::lateral_inhibition::LateralInhibition::invert`]):
//!    the cone activations `a (n, n)`. Without noise the inverse returns the activations the eye
//!    computed (to the solver's 1e-7), so the noise-free path takes those directly.
//! 2. **Kinds of cone**: every distinct weight row of the true mosaic is a kind (pure L, M, S, Q,
//!    or a co-expressing mixture such as ½L + ½M, whose sensitivity lies in the span of L and
//!    M). At most [`MAX_KINDS`].
//! 3. **Per-kind planes** `(K, n, n)`: with interpolation, plane q at cell j is the
//!    Gaussian-weighted mean of the activations of the kind-q cones near j (true positions;
//!    σ = half the mean distance between neighbouring kind-q cones, truncated at 2.5 σ, the
//!    nearest kind-q cone when none is that close) — an ideal demosaicker, exact inside any
//!    uniform region wider than the kernel. Without interpolation each cell keeps only its own
//!    kind (zero on the other planes): the analogue of a cortex with no demosaicker.
//! 4. **Embedding** in `N = 8` channels by a fixed random orthonormal map `(N × K)`, like the
//!    cortex's percept (paper §4: N = 8), so the dimension is not read off the channel count.
//!
//! A K-kind oracle with interpolation is a K-dimensional colour observer when the kinds'
//! sensitivities are linearly independent (Grassmann); a kind inside the span of the others
//! adds nothing.
//!
//! A mosaic of more kinds than [`MAX_KINDS`] — cones mixing two opsins each at its own ratio —
//! is demosaicked instead by weighted least squares over the mixtures
//! (`observer/mixed_opsins.rs`): its planes are the excitations of the opsins, as many as the rank
//! of the weight rows.

use rand::rngs::StdRng;
use rand::SeedableRng;
use retina::Retina;

/// Channels of the oracle percept (the cortex's N, paper §4 and the official code: 8).
pub const ORACLE_PERCEPT_DIM: usize = 8;
/// Most kinds of cone an oracle separates.
pub const MAX_KINDS: usize = 8;
/// Gaussian σ of the interpolation, in mean distances between neighbouring cones of a kind.
pub const INTERPOLATION_SIGMA_SPACINGS: f64 = 0.5;
/// Truncation of the interpolation kernel, in σ.
pub const INTERPOLATION_REACH_SIGMAS: f64 = 2.5;
/// Relative residual at which the LI inversion stops, and its iteration cap.
const LI_INVERSE_TOLERANCE: f64 = 1e-7;
const LI_INVERSE_MAX_ITERATIONS: usize = 400;

/// An oracle decoder for one eye (module docs).
#[derive(Clone, Debug)]
pub struct OracleDecoder {
    nn: usize,
    kinds: usize,
    kind_of: Vec<usize>,
    /// Per kind and cell, `(source cell, weight)` with weights summing to 1 (interpolation),
    /// or `None` (each cell keeps its own kind).
    taps: Option<Vec<Vec<(u32, f32)>>>,
    /// `(N × K)` with orthonormal columns.
    embedding: Vec<f32>,
    /// Whether the planes are least-squares estimates over mixed cones (`kinds` then counts
    /// planes: the rank of the mosaic's weight rows).
    mixtures: bool,
}

/// Why an oracle cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("the oracle decoder needs at most {MAX_KINDS} kinds of cone; this mosaic has {0} distinct weight rows (random co-expression ratios cannot be separated by kind)")]
pub struct TooManyKinds(pub usize);

impl OracleDecoder {
    /// The oracle of `retina`'s true mosaic, with or without per-kind interpolation; `seed`
    /// draws the embedding.
    ///
    /// A mosaic of more than [`MAX_KINDS`] kinds (cones mixing opsins at random ratios) is
    /// demosaicked by least squares over its mixtures (`observer/mixed_opsins.rs`) when
    /// interpolating, and refused without interpolation.
    pub fn new(retina: &Retina, interpolate: bool, seed: u64) -> Result<Self, TooManyKinds> {
        let nn = retina.n() * retina.n();
        let (kind_of, kinds, taps, mixtures) = match kinds_of(retina) {
            Ok((kind_of, kinds)) => {
                let taps = interpolate.then(|| interpolation_taps(retina, &kind_of, kinds));
                (kind_of, kinds, taps, false)
            }
            Err(_) if interpolate => {
                let (taps, planes) = super::mixed_opsins::least_squares_taps(retina);
                (Vec::new(), planes, Some(taps), true)
            }
            Err(too_many) => return Err(too_many),
        };
        Ok(OracleDecoder {
            nn,
            kinds,
            kind_of,
            taps,
            mixtures,
            embedding: colorimetry::linalg::random_orthonormal_columns(
                ORACLE_PERCEPT_DIM,
                kinds,
                &mut StdRng::seed_from_u64(seed),
            )
            .into_iter()
            .map(|v| v as f32)
            .collect(),
        })
    }

    /// Number of kinds of cone separated.
    pub fn kinds(&self) -> usize {
        self.kinds
    }

    /// Whether it interpolates each kind across the mosaic.
    pub fn interpolates(&self) -> bool {
        self.taps.is_some()
    }

    /// Whether it demosaicks cones of mixed opsins by least squares (more than [`MAX_KINDS`]
    /// kinds), its planes then the block excitations rather than kinds.
    pub fn solves_mixtures(&self) -> bool {
        self.mixtures
    }

    /// The activations behind `ons (n, n)`: `exact_activations` when the frame is noise-free
    /// (the exact LI inverse returns them), else the solved LI inverse.
    pub fn activations(retina: &Retina, ons: &[f32], exact: Option<&[f32]>) -> Vec<f32> {
        match (&retina.lateral_inhibition, exact) {
            (_, Some(a)) => a.to_vec(),
            (Some(li), None) => {
                let mut a = vec![0f32; ons.len()];
                li.invert(ons, &mut a, LI_INVERSE_TOLERANCE, LI_INVERSE_MAX_ITERATIONS);
                a
            }
            (None, None) => ons.to_vec(),
        }
    }

    /// Decode activations `(n, n)` into the percept `out (N, n, n)`.
    pub fn decode(&self, act: &[f32], out: &mut [f32]) {
        let nn = self.nn;
        assert!(
            act.len() == nn && out.len() == ORACLE_PERCEPT_DIM * nn,
            "OracleDecoder::decode: act {} and out {} for {nn} cells",
            act.len(),
            out.len()
        );
        let mut planes = vec![0f32; self.kinds * nn];
        match &self.taps {
            Some(taps) => {
                for (q, plane) in planes.chunks_exact_mut(nn).enumerate() {
                    for (j, v) in plane.iter_mut().enumerate() {
                        *v = taps[q * nn + j]
                            .iter()
                            .map(|&(i, w)| w * act[i as usize])
                            .sum();
                    }
                }
            }
            None => {
                for (j, &q) in self.kind_of.iter().enumerate() {
                    planes[q * nn + j] = act[j];
                }
            }
        }
        out.fill(0.0);
        for d in 0..ORACLE_PERCEPT_DIM {
            let dst = &mut out[d * nn..(d + 1) * nn];
            for q in 0..self.kinds {
                let e = self.embedding[d * self.kinds + q];
                for (o, p) in dst.iter_mut().zip(&planes[q * nn..(q + 1) * nn]) {
                    *o += e * p;
                }
            }
        }
    }
}

/// The kind of every cell (distinct weight rows, in order of first appearance).
pub(super) fn kinds_of(retina: &Retina) -> Result<(Vec<usize>, usize), TooManyKinds> {
    let k = retina.mosaic.n_classes();
    let key = |row: &[f32]| -> Vec<i64> { row.iter().map(|w| (w * 1e4).round() as i64).collect() };
    let mut rows: Vec<Vec<i64>> = Vec::new();
    let kind_of = retina
        .mosaic
        .weights
        .chunks_exact(k)
        .map(|row| {
            let r = key(row);
            match rows.iter().position(|x| *x == r) {
                Some(q) => q,
                None => {
                    rows.push(r);
                    rows.len() - 1
                }
            }
        })
        .collect();
    if rows.len() > MAX_KINDS {
        return Err(TooManyKinds(rows.len()));
    }
    Ok((kind_of, rows.len()))
}

/// Per kind and cell, the normalised Gaussian taps over the cones of that kind.
pub(super) fn interpolation_taps(
    retina: &Retina,
    kind_of: &[usize],
    kinds: usize,
) -> Vec<Vec<(u32, f32)>> {
    let mut taps = Vec::with_capacity(kinds * kind_of.len());
    for q in 0..kinds {
        let members: Vec<usize> = (0..kind_of.len()).filter(|&i| kind_of[i] == q).collect();
        let sigma = INTERPOLATION_SIGMA_SPACINGS * mean_spacing_px(retina, &members);
        for j in 0..kind_of.len() {
            let mut cell: Vec<(u32, f32)> = gaussian_neighbours(retina, &members, j, sigma)
                .into_iter()
                .map(|(m, g)| (members[m] as u32, g as f32))
                .collect();
            if cell.is_empty() {
                cell.push((members[nearest(retina, &members, j)] as u32, 1.0));
            }
            let total: f32 = cell.iter().map(|t| t.1).sum();
            cell.iter_mut().for_each(|t| t.1 /= total);
            taps.push(cell);
        }
    }
    taps
}

/// Squared distance between the cones of cells `a` and `b`, px².
fn distance2_px(retina: &Retina, a: usize, b: usize) -> f64 {
    let (p, q) = (retina.layout.positions_px[a], retina.layout.positions_px[b]);
    ((p[0] - q[0]) as f64).powi(2) + ((p[1] - q[1]) as f64).powi(2)
}

/// Mean distance from each of `members` (cells) to its nearest other member, px; the field's
/// side when there are fewer than two.
pub(super) fn mean_spacing_px(retina: &Retina, members: &[usize]) -> f64 {
    if members.len() < 2 {
        return retina.layout.field_px as f64;
    }
    members
        .iter()
        .map(|&a| {
            members
                .iter()
                .filter(|&&b| b != a)
                .map(|&b| distance2_px(retina, a, b))
                .fold(f64::INFINITY, f64::min)
                .sqrt()
        })
        .sum::<f64>()
        / members.len() as f64
}

/// The members within [`INTERPOLATION_REACH_SIGMAS`] σ of cell `j`, as (index into
/// `members`, Gaussian weight `exp(−d² / 2σ²)`), unnormalised.
pub(super) fn gaussian_neighbours(
    retina: &Retina,
    members: &[usize],
    j: usize,
    sigma_px: f64,
) -> Vec<(usize, f64)> {
    let reach2 = (INTERPOLATION_REACH_SIGMAS * sigma_px).powi(2);
    members
        .iter()
        .enumerate()
        .map(|(m, &i)| (m, distance2_px(retina, i, j)))
        .filter(|&(_, d2)| d2 <= reach2)
        .map(|(m, d2)| (m, (-d2 / (2.0 * sigma_px * sigma_px)).exp()))
        .collect()
}

/// The index into `members` of the member nearest cell `j`.
pub(super) fn nearest(retina: &Retina, members: &[usize], j: usize) -> usize {
    (0..members.len())
        .min_by(|&a, &b| {
            distance2_px(retina, members[a], j).total_cmp(&distance2_px(retina, members[b], j))
        })
        .expect("a kind or block has a cone")
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use retina::RetinaConfig;

    /// The `tiny` eye with cones `cones` (one scene tile).
    pub(in crate::observer) fn eye(cones: &str) -> Retina {
        let mut c = RetinaConfig::tiny();
        c.cones = cones.into();
        c.scenes.tiles = 1;
        Retina::new(c).unwrap()
    }

    /// Activations of a uniform field with class excitations `values`.
    pub(in crate::observer) fn uniform(retina: &Retina, values: &[f32]) -> Vec<f32> {
        let k = retina.mosaic.n_classes();
        retina
            .mosaic
            .weights
            .chunks_exact(k)
            .map(|w| w.iter().zip(values).map(|(a, b)| a * b).sum())
            .collect()
    }

    /// Asserts that every cell of the percept `out (N, nn)` has squared norm `norm2` (within
    /// `tolerance`): a uniform field decoded exactly, through the orthonormal embedding.
    pub(in crate::observer) fn assert_percept_norms(out: &[f32], norm2: f32, tolerance: f32) {
        let nn = out.len() / ORACLE_PERCEPT_DIM;
        for j in 0..nn {
            let v2: f32 = (0..ORACLE_PERCEPT_DIM)
                .map(|d| out[d * nn + j].powi(2))
                .sum();
            assert!(
                (v2 - norm2).abs() < tolerance,
                "cell {j}: |percept|² {v2} vs {norm2}"
            );
        }
    }

    #[test]
    fn kinds_are_the_distinct_weight_rows() {
        let o = |c: &str| OracleDecoder::new(&eye(c), true, 0).unwrap().kinds();
        assert_eq!(o("L"), 1);
        assert_eq!(o("LM"), 2);
        assert_eq!(o("LMS"), 3);
        // ½L + ½M co-expressing cones are a fourth kind.
        assert_eq!(o("LMS+L_coexpress_M"), 4);
        // Random ratios: too many kinds; interpolated by least squares instead, else refused.
        let random_ratios = eye("MS+L_ratio_M");
        assert!(matches!(kinds_of(&random_ratios), Err(TooManyKinds(k)) if k > MAX_KINDS));
        assert!(!OracleDecoder::new(&eye("LMS"), true, 0)
            .unwrap()
            .solves_mixtures());
        assert!(OracleDecoder::new(&random_ratios, true, 0)
            .unwrap()
            .solves_mixtures());
        let bare = OracleDecoder::new(&random_ratios, false, 0);
        assert!(matches!(bare, Err(TooManyKinds(k)) if k > MAX_KINDS));
    }

    #[test]
    fn interpolation_reproduces_uniform_planes_and_embedding_is_orthonormal() {
        let retina = eye("LMS");
        let o = OracleDecoder::new(&retina, true, 3).unwrap();
        let nn = retina.n() * retina.n();
        let values = [0.7f32, 0.4, 0.9];
        let act = uniform(&retina, &values);
        let mut out = vec![0f32; ORACLE_PERCEPT_DIM * nn];
        o.decode(&act, &mut out);
        // Every cell: the embedded vector of the three class values, whose norm is theirs.
        assert_percept_norms(&out, values.iter().map(|v| v * v).sum(), 1e-4);
        // Without interpolation the percept norm is the cell's own activation.
        let bare = OracleDecoder::new(&retina, false, 3).unwrap();
        bare.decode(&act, &mut out);
        for j in 0..nn {
            let v2: f32 = (0..ORACLE_PERCEPT_DIM)
                .map(|d| out[d * nn + j].powi(2))
                .sum();
            assert!((v2 - act[j] * act[j]).abs() < 1e-4, "cell {j}");
        }
    }
}
