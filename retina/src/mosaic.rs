//! The cone mosaic: which cone class (or mixture of classes) sits at each lattice cell.
//!
//! Stage `Mosaic::compute(spec, n, seed)`:
//! - input: a [`MosaicSpec`] (parsed from strings such as `LMS`, `MS+L_coexpress_M`), the
//!   lattice side `n` (cells) and a seed;
//! - output: a [`Mosaic`] holding the distinct classes (name + λmax) and per-cell weights over
//!   them, row-major `(n·n, k)`, each row summing to 1. Weights are fractional only for
//!   co-expression (authors' code, docs/references.md#cone-mosaic: "entries may be fractional").
//!
//! Generation (authors' code, docs/references.md#cone-mosaic, `generate_cone_mosaic.py`):
//! - trichromat: every cell L with probability r/(1+r) (r = 1.92) else M, i.i.d.; then cells are
//!   visited in random order and a cell becomes S when the window rows `[i−3, i+3)` × cols
//!   `[j−3, j+3)` (clipped at the borders) holds no S yet. At 256² this gives L .624 / M .321 /
//!   S .055 (the paper's .63/.32/.05, Sabesan 2015).
//! - dichromats convert the trichromat: `LM` each S → L or M with ½; `LS` M → L; `MS` L → M.
//! - modifications (tetra, gene therapy, boosts) then affect each eligible cone with the given
//!   probability. The base uses `seed`, conversions and modifications a second stream
//!   `seed + 3` (the official code uses numpy seeds 0 and 3), so `MS` and `MS+L_replace_M` with
//!   the same seed share their base and differ only in the affected cones.

mod spec;

pub use spec::{
    canonical_order, Arrangement, Expression, Modification, MosaicSpec, DEFAULT_L_TO_M_RATIO,
    DEFAULT_MODIFICATION_FRACTION, DEFAULT_S_EXCLUSION_WINDOW_CELLS,
};

use colorimetry::cones::ConeClass;
use rand::rngs::StdRng;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};

use crate::error::Result;

/// Offset between the base seed and the seed of conversions and modifications (official: numpy
/// seeds 0 and 3).
pub const MODIFICATION_SEED_OFFSET: u64 = 3;

/// Cone classes and per-cell weights on an `n × n` lattice.
#[derive(Debug, Clone, PartialEq)]
pub struct Mosaic {
    /// Cells per side.
    pub n: usize,
    /// The distinct classes present, canonical order (L, M, S, Q, others).
    pub classes: Vec<ConeClass>,
    /// Row-major `(n·n, classes.len())`; each row sums to 1.
    pub weights: Vec<f32>,
    /// The specification string it was built from.
    pub spec_text: String,
}

/// Work array: per-cell weights over a growing list of class names.
struct WeightMap {
    names: Vec<String>,
    cells: usize,
    w: Vec<Vec<f32>>, // w[class][cell]
}

impl WeightMap {
    fn new(cells: usize) -> Self {
        WeightMap {
            names: vec![],
            cells,
            w: vec![],
        }
    }
    fn class(&mut self, name: &str) -> usize {
        if let Some(i) = self.names.iter().position(|n| n == name) {
            return i;
        }
        self.names.push(name.to_string());
        self.w.push(vec![0.0; self.cells]);
        self.names.len() - 1
    }
    fn set_pure(&mut self, cell: usize, class: usize) {
        for col in &mut self.w {
            col[cell] = 0.0;
        }
        self.w[class][cell] = 1.0;
    }
    /// Move all of `from`'s weight at every cell to `to`.
    fn merge(&mut self, from: usize, to: usize) {
        for cell in 0..self.cells {
            let v = std::mem::take(&mut self.w[from][cell]);
            self.w[to][cell] += v;
        }
    }
}

impl Mosaic {
    /// Build the mosaic of `spec` on an `n × n` lattice (see the module docs).
    pub fn compute(spec: &MosaicSpec, n: usize, seed: u64) -> Result<Mosaic> {
        assert!(n > 0, "Mosaic::compute: n must be > 0");
        let cells = n * n;
        let mut base_rng = StdRng::seed_from_u64(seed);
        let mut mod_rng = StdRng::seed_from_u64(seed.wrapping_add(MODIFICATION_SEED_OFFSET));
        let mut map = WeightMap::new(cells);
        match &spec.arrangement {
            spec::Arrangement::Trichromat => trichromat(&mut map, spec, n, &mut base_rng),
            spec::Arrangement::Dichromat { keep } => {
                trichromat(&mut map, spec, n, &mut base_rng);
                let (l, m, s) = (map.class("L"), map.class("M"), map.class("S"));
                let has = |c: &str| keep.iter().any(|k| k == c);
                if !has("S") {
                    for cell in 0..cells {
                        if map.w[s][cell] > 0.0 {
                            let to = if mod_rng.random::<f64>() < 0.5 { l } else { m };
                            map.set_pure(cell, to);
                        }
                    }
                } else if !has("M") {
                    map.merge(m, l);
                } else {
                    map.merge(l, m);
                }
            }
            spec::Arrangement::Mono(c) => {
                let c = map.class(c);
                map.w[c].fill(1.0);
            }
            spec::Arrangement::Iid(ratios) => {
                let total: f64 = ratios.iter().map(|(_, w)| w).sum();
                let idx: Vec<usize> = ratios.iter().map(|(name, _)| map.class(name)).collect();
                for cell in 0..cells {
                    let mut u = base_rng.random::<f64>() * total;
                    let mut pick = idx[idx.len() - 1];
                    for (k, (_, w)) in ratios.iter().enumerate() {
                        if u < *w {
                            pick = idx[k];
                            break;
                        }
                        u -= w;
                    }
                    map.w[pick][cell] = 1.0;
                }
            }
        }
        for m in &spec.modifications {
            let targets: Vec<usize> = m.targets.iter().map(|t| map.class(t)).collect();
            let new = map.class(&m.new_class);
            for cell in 0..cells {
                let eligible: f32 = targets.iter().map(|&t| map.w[t][cell]).sum();
                if eligible <= 0.0 || mod_rng.random::<f64>() >= m.fraction {
                    continue;
                }
                let share = match m.expression {
                    spec::Expression::Replace => 1.0,
                    spec::Expression::Coexpress => 0.5,
                    spec::Expression::Ratio => mod_rng.random::<f32>(),
                };
                for &t in &targets {
                    if t == new {
                        continue;
                    }
                    let moved = map.w[t][cell] * share;
                    map.w[t][cell] -= moved;
                    map.w[new][cell] += moved;
                }
            }
        }
        let present: Vec<String> = map
            .names
            .iter()
            .zip(&map.w)
            .filter(|(_, col)| col.iter().any(|&v| v > 0.0))
            .map(|(n, _)| n.clone())
            .collect();
        let order = canonical_order(present);
        let classes = order
            .iter()
            .map(|name| spec.class(name))
            .collect::<Result<Vec<_>>>()?;
        let k = classes.len();
        let mut weights = vec![0.0f32; cells * k];
        for (c, name) in order.iter().enumerate() {
            let col = &map.w[map.names.iter().position(|n| n == name).expect("present")];
            for cell in 0..cells {
                weights[cell * k + c] = col[cell];
            }
        }
        for row in weights.chunks_mut(k) {
            let s: f32 = row.iter().sum();
            row.iter_mut().for_each(|v| *v /= s);
        }
        Ok(Mosaic {
            n,
            classes,
            weights,
            spec_text: spec.text.clone(),
        })
    }

    /// Parse `text` and build (convenience for [`MosaicSpec::parse`] + [`Mosaic::compute`]).
    pub fn from_spec_str(text: &str, n: usize, seed: u64) -> Result<Mosaic> {
        Mosaic::compute(&MosaicSpec::parse(text)?, n, seed)
    }

    /// Number of distinct classes.
    pub fn n_classes(&self) -> usize {
        self.classes.len()
    }

    /// The classes' names, in class order.
    pub fn class_names(&self) -> Vec<String> {
        self.classes.iter().map(|c| c.name.clone()).collect()
    }

    /// The class weights of cell `(row, col)`.
    pub fn cell(&self, row: usize, col: usize) -> &[f32] {
        let k = self.classes.len();
        let i = row * self.n + col;
        &self.weights[i * k..(i + 1) * k]
    }

    /// Index of the class with the largest weight at each cell, row-major `(n, n)`.
    pub fn dominant_class(&self) -> Vec<usize> {
        self.weights
            .chunks(self.classes.len())
            .map(|row| {
                (0..row.len())
                    .max_by(|&a, &b| row[a].total_cmp(&row[b]))
                    .expect("k ≥ 1")
            })
            .collect()
    }

    /// Summed weight of each class (for pure mosaics: the cone counts).
    pub fn class_totals(&self) -> Vec<f64> {
        let k = self.classes.len();
        let mut t = vec![0.0; k];
        for row in self.weights.chunks(k) {
            for (a, &v) in t.iter_mut().zip(row) {
                *a += v as f64;
            }
        }
        t
    }

    /// [`Mosaic::class_totals`] divided by the number of cells.
    pub fn class_fractions(&self) -> Vec<f64> {
        let cells = (self.n * self.n) as f64;
        self.class_totals().into_iter().map(|t| t / cells).collect()
    }

    /// Index of the class with this name.
    pub fn class_index(&self, name: &str) -> Option<usize> {
        self.classes.iter().position(|c| c.name == name)
    }

    /// Weights as a `(k, n, n)` class-major array (the official 4-channel map's layout).
    pub fn class_maps(&self) -> Vec<f32> {
        let (k, cells) = (self.classes.len(), self.n * self.n);
        let mut out = vec![0.0; k * cells];
        for cell in 0..cells {
            for c in 0..k {
                out[c * cells + cell] = self.weights[cell * k + c];
            }
        }
        out
    }
}

/// Trichromat: L/M i.i.d., then greedy S insertion with the exclusion window.
fn trichromat(map: &mut WeightMap, spec: &MosaicSpec, n: usize, rng: &mut StdRng) {
    let (l, m, s) = (map.class("L"), map.class("M"), map.class("S"));
    let p_l = spec.l_to_m_ratio / (1.0 + spec.l_to_m_ratio);
    for cell in 0..n * n {
        let c = if rng.random::<f64>() < p_l { l } else { m };
        map.w[c][cell] = 1.0;
    }
    let mut order: Vec<usize> = (0..n * n).collect();
    order.shuffle(rng);
    let half = spec.s_exclusion_window_cells / 2;
    let upper = spec.s_exclusion_window_cells - half;
    let mut is_s = vec![false; n * n];
    for cell in order {
        let (i, j) = (cell / n, cell % n);
        let (r0, r1) = (i.saturating_sub(half), (i + upper).min(n));
        let (c0, c1) = (j.saturating_sub(half), (j + upper).min(n));
        let free = (r0..r1).all(|r| (c0..c1).all(|c| !is_s[r * n + c]));
        if free {
            is_s[cell] = true;
            map.set_pure(cell, s);
        }
    }
}

#[cfg(test)]
mod tests;
