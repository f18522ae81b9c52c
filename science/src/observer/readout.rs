//! How a percept image becomes the vector CMF-SIM compares: the readout of one patch.
//!
//! The decoder's percept is an image `(dim, n, n)` on the cone lattice. Two readouts:
//! - **Resolved** (default): a fixed grid of sample offsets inside the disc shrunk by
//!   `fringe_cones` cone spacings, spaced `sample_spacing_cones` mean cone spacings apart,
//!   relative to the patch centre. Each offset reads the percept of the cone nearest to
//!   `centre + offset` (true positions, field px). The readout is the `(samples × dim)` vector
//!   divided by √samples, so its squared distance is the *mean over the patch* of the
//!   per-point squared distance. Two patches are compared point by point in patch-relative
//!   coordinates, like two surfaces seen side by side: a percept that copies the cone mosaic
//!   (a different texture at every location) differs between locations even when its patch
//!   means agree.
//! - **PatchMean**: the mean percept over the cones inside the shrunk disc (`dim` values).
//!   Averaging hides the mosaic, and the location-to-location change of the cone mix then
//!   acts like an extra colour dimension: an observer that is 1-D at every location can match
//!   a shared α only with two primaries. Kept to show that failure (`readout = "patch-mean"`).
//!
//! Why resolved: with it, the known-answer observers through the real eye return their
//! answers (the percept of the ONS itself has no colour constancy; raw cone activations are
//! 1-D; oracle decoders with K classes are K-D), while patch means score the first two as
//! 2-D (tests in `tests.rs`, the table in the README).

use retina::foveation::ConeLayout;
use serde::{Deserialize, Serialize};

/// Which readout (module docs).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum ReadoutMode {
    /// Point by point in patch-relative coordinates.
    Resolved,
    /// The mean over the patch.
    PatchMean,
}

/// The readout geometry of one eye (module docs).
#[derive(Clone, Debug, PartialEq)]
pub struct Readout {
    mode: ReadoutMode,
    /// Sample offsets from the patch centre, field px (resolved only).
    offsets_px: Vec<[f64; 2]>,
    /// Radius of the read disc, field px.
    read_radius_px: f64,
}

/// The rows and columns (inclusive) of the smallest box of the `n × n` grid holding `cells`
/// (row-major indices; `None` when there is none): what a cortex decodes a patch's cells on.
pub fn cells_box(cells: &[usize], n: usize) -> Option<([usize; 2], [usize; 2])> {
    (!cells.is_empty()).then(|| {
        cells.iter().fold(([n, 0], [n, 0]), |(r, c), &i| {
            let (y, x) = (i / n, i % n);
            ([r[0].min(y), r[1].max(y)], [c[0].min(x), c[1].max(x)])
        })
    })
}

impl Readout {
    /// The readout of a disc of `radius_px` on `layout`.
    pub fn new(
        mode: ReadoutMode,
        layout: &ConeLayout,
        radius_px: f64,
        fringe_cones: f64,
        sample_spacing_cones: f64,
    ) -> Self {
        let spacing_px = layout.field_px as f64 / layout.n as f64;
        let read_radius_px = (radius_px - fringe_cones * spacing_px).max(spacing_px);
        let step = sample_spacing_cones * spacing_px;
        let half = (read_radius_px / step).floor() as i64;
        let mut offsets_px = Vec::new();
        for iy in -half..=half {
            for ix in -half..=half {
                let o = [ix as f64 * step, iy as f64 * step];
                if o[0] * o[0] + o[1] * o[1] <= read_radius_px * read_radius_px {
                    offsets_px.push(o);
                }
            }
        }
        Readout {
            mode,
            offsets_px,
            read_radius_px,
        }
    }

    /// Which readout.
    pub fn mode(&self) -> ReadoutMode {
        self.mode
    }

    /// Number of sample points (1 for the patch mean).
    pub fn samples(&self) -> usize {
        match self.mode {
            ReadoutMode::Resolved => self.offsets_px.len(),
            ReadoutMode::PatchMean => 1,
        }
    }

    /// Length of a readout vector for a percept of `dim` channels.
    pub fn len(&self, dim: usize) -> usize {
        self.samples() * dim
    }

    /// The cones read for a patch centred at `centre_px`: one per sample offset (resolved), or
    /// every cone inside the read disc (patch mean; the nearest cone if none is inside).
    pub fn cells(&self, layout: &ConeLayout, centre_px: [f64; 2]) -> Vec<usize> {
        let dist2 = |i: usize, p: [f64; 2]| {
            let q = layout.positions_px[i];
            (q[0] as f64 - p[0]).powi(2) + (q[1] as f64 - p[1]).powi(2)
        };
        let nearest = |p: [f64; 2], among: &[usize]| -> usize {
            *among
                .iter()
                .min_by(|&&a, &&b| dist2(a, p).total_cmp(&dist2(b, p)))
                .expect("a layout has cones")
        };
        let all: Vec<usize> = (0..layout.n * layout.n).collect();
        let r = self.read_radius_px;
        let inside: Vec<usize> = all
            .iter()
            .copied()
            .filter(|&i| dist2(i, centre_px) <= r * r)
            .collect();
        match self.mode {
            ReadoutMode::PatchMean if inside.is_empty() => vec![nearest(centre_px, &all)],
            ReadoutMode::PatchMean => inside,
            ReadoutMode::Resolved => {
                // Nearest cones of the sample points lie within a few spacings of the disc.
                let reach = r + 4.0 * layout.field_px as f64 / layout.n as f64;
                let near: Vec<usize> = all
                    .into_iter()
                    .filter(|&i| dist2(i, centre_px) <= reach * reach)
                    .collect();
                let near = if near.is_empty() {
                    (0..layout.n * layout.n).collect()
                } else {
                    near
                };
                self.offsets_px
                    .iter()
                    .map(|o| nearest([centre_px[0] + o[0], centre_px[1] + o[1]], &near))
                    .collect()
            }
        }
    }

    /// Read `planes (dim, n·n)` at `cells` into `out (self.len(dim))`.
    pub fn read(&self, planes: &[f32], dim: usize, cells: &[usize], out: &mut [f64]) {
        let nn = planes.len() / dim.max(1);
        assert_eq!(
            out.len(),
            self.len(dim),
            "Readout::read: out has {} values, the readout {}",
            out.len(),
            self.len(dim)
        );
        match self.mode {
            ReadoutMode::Resolved => {
                let scale = 1.0 / (cells.len() as f64).sqrt();
                for (s, &i) in cells.iter().enumerate() {
                    for d in 0..dim {
                        out[s * dim + d] = planes[d * nn + i] as f64 * scale;
                    }
                }
            }
            ReadoutMode::PatchMean => {
                for d in 0..dim {
                    let plane = &planes[d * nn..(d + 1) * nn];
                    out[d] =
                        cells.iter().map(|&i| plane[i] as f64).sum::<f64>() / cells.len() as f64;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use retina::foveation::LayoutConfig;

    fn layout() -> ConeLayout {
        ConeLayout::compute(&LayoutConfig::Identity, 32, 32, 0)
    }

    #[test]
    fn resolved_samples_tile_the_read_disc_once_per_spacing() {
        let l = layout();
        let r = Readout::new(ReadoutMode::Resolved, &l, 8.0, 1.0, 1.0);
        // radius 7 px on a 1-px lattice: the lattice points inside a disc of radius 7.
        assert_eq!(r.samples(), 149);
        let cells = r.cells(&l, [15.0, 16.0]);
        let mut unique = cells.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(
            unique.len(),
            cells.len(),
            "one cone per sample on the identity lattice"
        );
        // the centre sample reads the cone at the centre: (x 15, y 16) is cell 16·32 + 15.
        assert!(cells.contains(&(16 * 32 + 15)));
    }

    #[test]
    fn resolved_distance_is_the_mean_pointwise_distance_and_means_hide_texture() {
        let l = layout();
        let nn = 32 * 32;
        // A checkerboard percept: its patch mean is the same everywhere, its texture is not.
        let planes: Vec<f32> = (0..nn).map(|i| ((i / 32 + i % 32) % 2) as f32).collect();
        let resolved = Readout::new(ReadoutMode::Resolved, &l, 6.0, 1.0, 1.0);
        let mean = Readout::new(ReadoutMode::PatchMean, &l, 6.0, 1.0, 1.0);
        let read = |r: &Readout, c: [f64; 2]| {
            let mut out = vec![0.0; r.len(1)];
            r.read(&planes, 1, &r.cells(&l, c), &mut out);
            out
        };
        let d2 = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum::<f64>();
        // Shifted by one cone the checkerboard flips at every point: mean squared distance 1.
        let (a, b) = (read(&resolved, [10.0, 10.0]), read(&resolved, [21.0, 10.0]));
        assert!((d2(&a, &b) - 1.0).abs() < 1e-12, "{}", d2(&a, &b));
        let (a, b) = (read(&mean, [10.0, 10.0]), read(&mean, [21.0, 10.0]));
        assert!(
            d2(&a, &b) < 0.01,
            "patch means nearly agree: {}",
            d2(&a, &b)
        );
    }
}
