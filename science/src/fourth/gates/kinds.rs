//! The cone kinds a gate reads: pure L, M and S cones, and the fourth kind (module docs of
//! [`super`]). Lattice `(n, n)` row-major; excitations `(k, n, n)` planar, class order of the
//! mosaic.

use super::{QConeSums, DEMOSAIC_MAX_RADIUS_CELLS, GATE_BORDER_CELLS};
use crate::fourth::own_signal::TileSites;
use crate::Error;
use rand::rngs::StdRng;
use retina::Retina;

/// Which cell is which kind.
pub(super) struct Kinds {
    /// Class indices of L, M, S.
    lms: [usize; 3],
    /// The fourth kind's weights over the classes.
    q_row: Vec<f32>,
    /// Per cell: `Some(0 | 1 | 2)` for a pure L, M or S cone, `Some(3)` for the fourth kind.
    kind: Vec<Option<usize>>,
    n: usize,
    k: usize,
}

impl Kinds {
    /// The kinds of `retina`'s mosaic. Error if it lacks L, M or S, or a fourth kind.
    pub(super) fn of(retina: &Retina) -> Result<Kinds, Error> {
        let mosaic = &retina.mosaic;
        let k = mosaic.n_classes();
        let class = |name: &str| {
            mosaic
                .classes
                .iter()
                .position(|c| c.name == name)
                .ok_or_else(|| {
                    Error::invalid(
                        "cones",
                        format!(
                            "`{}` has no {name} class; a gate needs L, M and S",
                            mosaic.spec_text
                        ),
                    )
                })
        };
        let lms = [class("L")?, class("M")?, class("S")?];
        let rows: Vec<&[f32]> = mosaic.weights.chunks_exact(k).collect();
        let pure = |row: &[f32]| lms.iter().position(|&c| row[c] == 1.0);
        let mut counts: Vec<(&[f32], usize)> = Vec::new();
        for &row in &rows {
            if pure(row).is_some() {
                continue;
            }
            match counts.iter_mut().find(|(r, _)| *r == row) {
                Some((_, c)) => *c += 1,
                None => counts.push((row, 1)),
            }
        }
        let q_row = counts
            .iter()
            .max_by_key(|(_, c)| *c)
            .map(|(r, _)| r.to_vec())
            .ok_or_else(|| {
                Error::invalid(
                    "cones",
                    format!("`{}` has no fourth kind of cone", mosaic.spec_text),
                )
            })?;
        let kind = rows
            .iter()
            .map(|&r| pure(r).or((r == q_row.as_slice()).then_some(3)))
            .collect();
        Ok(Kinds {
            lms,
            q_row,
            kind,
            n: mosaic.n,
            k,
        })
    }

    /// The cells at least [`GATE_BORDER_CELLS`] from the edge.
    fn inner(&self) -> impl Iterator<Item = usize> + '_ {
        let (n, b) = (self.n, GATE_BORDER_CELLS);
        (b..n.saturating_sub(b)).flat_map(move |y| (b..n - b).map(move |x| y * n + x))
    }

    /// `[L, M, S, Q]` at cell `i` of excitations `e`.
    fn lmsq(&self, e: &[f32], i: usize) -> [f64; 4] {
        let nn = self.n * self.n;
        let at = |c: usize| e[c * nn + i] as f64;
        let q = (0..self.k).map(|c| self.q_row[c] as f64 * at(c)).sum();
        [at(self.lms[0]), at(self.lms[1]), at(self.lms[2]), q]
    }

    /// The inner sites of one crop.
    pub(super) fn sites(&self, e: &[f32], retina: &Retina) -> TileSites {
        debug_assert_eq!(e.len(), self.k * retina.n() * retina.n());
        self.inner().map(|i| self.lmsq(e, i)).collect()
    }

    /// Mean excitation of class `kind` (0, 1, 2: L, M, S) over the pure cones of that kind in
    /// the smallest window around cell `i` that holds one (`None` if none within the largest).
    fn neighbours_mean(&self, e: &[f32], i: usize, kind: usize) -> Option<f64> {
        let (n, nn) = (self.n as isize, self.n * self.n);
        let (y, x) = ((i / self.n) as isize, (i % self.n) as isize);
        for r in 1..=DEMOSAIC_MAX_RADIUS_CELLS as isize {
            let (mut sum, mut count) = (0.0, 0usize);
            for yy in (y - r).max(0)..=(y + r).min(n - 1) {
                for xx in (x - r).max(0)..=(x + r).min(n - 1) {
                    let j = (yy * n + xx) as usize;
                    if j != i && self.kind[j] == Some(kind) {
                        sum += e[self.lms[kind] * nn + j] as f64;
                        count += 1;
                    }
                }
            }
            if count > 0 {
                return Some(sum / count as f64);
            }
        }
        None
    }

    /// Adds one held-out crop's Q-cone figures to `sums` (module docs of [`super`]): its
    /// activation, the demosaicking error of the fit `fit`, and the ONS variances of Q's own
    /// part and of the noise (at r = 1).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn add_q_cone_sums(
        &self,
        retina: &Retina,
        tile: usize,
        origin: [i32; 2],
        e: &[f32],
        fit: &[f64; 4],
        rng: &mut StdRng,
        sums: &mut QConeSums,
    ) {
        let nn = self.n * self.n;
        let predict = |v: [f64; 4]| fit[0] + fit[1] * v[0] + fit[2] * v[1] + fit[3] * v[2];
        let mut own = vec![0.0f32; nn];
        for i in (0..nn).filter(|&i| self.kind[i] == Some(3)) {
            let v = self.lmsq(e, i);
            own[i] = (v[3] - predict(v)) as f32;
        }
        let stack = retina.pool.tile(tile);
        let (mut act, mut clean, mut noisy) = (vec![0.0; nn], vec![0.0; nn], vec![0.0; nn]);
        retina.encode_frame(stack, origin, &mut act, &mut clean);
        retina.encode_frame_noisy(rng, 1.0, stack, origin, &mut act, &mut noisy);
        let mut own_ons = vec![0.0f32; nn];
        match &retina.lateral_inhibition {
            Some(li) => li.compute(&own, &mut own_ons),
            None => own_ons.copy_from_slice(&own),
        }
        for i in self.inner().filter(|&i| self.kind[i] == Some(3)) {
            let v = self.lmsq(e, i);
            let near: Option<Vec<f64>> = (0..3).map(|c| self.neighbours_mean(e, i, c)).collect();
            let Some(near) = near else { continue };
            let err: f64 = (0..3).map(|c| fit[c + 1] * (near[c] - v[c])).sum();
            sums.cones += 1;
            sums.activation += v[3].max(0.0);
            sums.demosaic_sq += err * err;
            sums.ons_own_sq += (own_ons[i] as f64).powi(2);
            sums.ons_noise_sq += ((noisy[i] - clean[i]) as f64).powi(2);
        }
    }
}
