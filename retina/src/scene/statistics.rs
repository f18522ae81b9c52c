//! Spatial statistics of colour in a scene, the yardstick a synthetic generator is matched to
//! photographs with.
//!
//! Input: linear L, M, S planes `(3, h, w)` at the eyes' scale of 2 px per cone (photographs:
//! linear sRGB through the official sRGB → cone matrix after resizing, in linear light, so
//! that the short side is 542 px, the authors' preprocessing of ARAD_1K; scene tiles: as the
//! pool makes them). Every statistic is measured on non-overlapping `CROP_PX` crops (what an
//! eye's tile holds) and averaged over them.
//!
//! Channels: log luminance `ln(L + M)`, and the chromatic ratios `(L − M)/(L + M)` (red–green)
//! and `S/(L + M)` (blue–yellow), which shading and illumination intensity leave unchanged.
//! Statistics, for the distances `DISTANCES_PX`:
//! - **autocorrelation** of each channel: Pearson's r between the values at `p` and `p + d`,
//!   horizontal and vertical pairs pooled;
//! - **same colour**: the share of those pairs whose chromatic distance,
//!   `√((Δrg/σ_rg)² + (Δby/σ_by)²)` with σ each ratio's standard deviation over the crop, is
//!   below `SAME_COLOUR_TOLERANCE` (fixed before any generator was fitted);
//! - **contrast**: the standard deviation over the crop of log luminance and of the two
//!   ratios (`contrast_sd`), and the root-mean-square difference of the red–green ratio
//!   between the two points of a pair (`red_green_difference_rms`, per distance): how far the
//!   `L − M` balance moves between two cones `d` apart, the signal an eye with few cones of
//!   each class has to read colour from (the autocorrelations are normalised and do not say);
//! - **spectral slopes**: the least-squares slope of log power on log frequency, 4 cycles per
//!   crop to a quarter of the sampling rate ([`crate::analysis::power_spectrum_slope`]), of the
//!   opponent contrasts `(L+M)/⟨L+M⟩ − 1`, `L/⟨L⟩ − M/⟨M⟩` and `S/⟨S⟩ − (L+M)/⟨L+M⟩`.

use serde::{Deserialize, Serialize};

use crate::analysis::power_spectrum_slope;

/// Pair distances, px.
pub const DISTANCES_PX: [usize; 10] = [1, 2, 3, 4, 6, 8, 12, 16, 24, 32];
/// Distance between neighbouring cones at the eyes' scale (2 px per cone), px.
pub const NEIGHBOUR_CONES_PX: usize = 2;

/// The index of `d_px` in [`DISTANCES_PX`]. Panics if it is not one of them.
#[track_caller]
pub fn distance_index(d_px: usize) -> usize {
    DISTANCES_PX
        .iter()
        .position(|&d| d == d_px)
        .unwrap_or_else(|| panic!("{d_px} px is not one of DISTANCES_PX {DISTANCES_PX:?}"))
}

/// Chromatic distance, in units of the crop's own chromatic standard deviation, below which
/// two points count as the same colour.
pub const SAME_COLOUR_TOLERANCE: f64 = 0.25;
/// Side of the crops statistics are measured on, px (the quick eye's tile).
pub const CROP_PX: usize = 192;

/// The statistics of one crop or their mean over many (module docs), one value per distance.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SpatialStatistics {
    /// Autocorrelation of log luminance.
    pub log_luminance: Vec<f64>,
    /// Autocorrelation of `(L − M)/(L + M)`.
    pub red_green: Vec<f64>,
    /// Autocorrelation of `S/(L + M)`.
    pub blue_yellow: Vec<f64>,
    /// Share of pairs of the same colour.
    pub same_colour: Vec<f64>,
    /// Power-spectrum slopes of the luminance, red–green and blue–yellow contrasts (NaN for a
    /// contrast that is the same everywhere: it has no spectrum).
    pub spectral_slopes: [f64; 3],
    /// Standard deviation over the crop of log luminance (natural log: a unit is a factor of
    /// e), `(L − M)/(L + M)` and `S/(L + M)` (the ratios have no unit; like the other
    /// statistics, `L + M` here carries the crop's `ε = 1e-3·⟨L + M⟩`).
    pub contrast_sd: [f64; 3],
    /// Root-mean-square of `rg(p) − rg(p + d)`, `rg = (L − M)/(L + M + ε)`, over the pairs; one
    /// value per distance of [`DISTANCES_PX`].
    pub red_green_difference_rms: Vec<f64>,
}

impl SpatialStatistics {
    /// The four curves with their names, in a fixed order.
    pub fn curves(&self) -> [(&'static str, &[f64]); 4] {
        [
            ("log luminance", &self.log_luminance),
            ("red-green", &self.red_green),
            ("blue-yellow", &self.blue_yellow),
            ("same colour", &self.same_colour),
        ]
    }

    /// The element-wise mean of `all` (not empty).
    pub fn mean(all: &[SpatialStatistics]) -> SpatialStatistics {
        assert!(!all.is_empty(), "SpatialStatistics::mean of nothing");
        let n = all.len() as f64;
        let avg = |f: fn(&SpatialStatistics) -> &Vec<f64>| -> Vec<f64> {
            (0..DISTANCES_PX.len())
                .map(|i| all.iter().map(|s| f(s)[i]).sum::<f64>() / n)
                .collect()
        };
        let avg3 = |f: fn(&SpatialStatistics) -> &[f64; 3]| -> [f64; 3] {
            std::array::from_fn(|c| all.iter().map(|s| f(s)[c]).sum::<f64>() / n)
        };
        SpatialStatistics {
            log_luminance: avg(|s| &s.log_luminance),
            red_green: avg(|s| &s.red_green),
            blue_yellow: avg(|s| &s.blue_yellow),
            same_colour: avg(|s| &s.same_colour),
            spectral_slopes: avg3(|s| &s.spectral_slopes),
            contrast_sd: avg3(|s| &s.contrast_sd),
            red_green_difference_rms: avg(|s| &s.red_green_difference_rms),
        }
    }
}

/// Pearson's r of the pairs `(x[p], x[p + d])`, horizontal and vertical, over a `size²` crop.
fn autocorrelation(x: &[f64], size: usize, d: usize) -> f64 {
    let (mut n, mut sa, mut sb, mut saa, mut sbb, mut sab) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
    for_pairs(size, d, |p, q| {
        let (a, b) = (x[p], x[q]);
        n += 1.0;
        sa += a;
        sb += b;
        saa += a * a;
        sbb += b * b;
        sab += a * b;
    });
    let cov = sab / n - (sa / n) * (sb / n);
    let va = saa / n - (sa / n).powi(2);
    let vb = sbb / n - (sb / n).powi(2);
    cov / (va * vb).sqrt().max(1e-300)
}

/// Calls `f(p, q)` for every horizontal and vertical pair `d` apart in a `size²` crop.
fn for_pairs(size: usize, d: usize, mut f: impl FnMut(usize, usize)) {
    for y in 0..size {
        for x in 0..size {
            let p = y * size + x;
            if x + d < size {
                f(p, p + d);
            }
            if y + d < size {
                f(p, p + d * size);
            }
        }
    }
}

/// Root-mean-square of `x[p] − x[p + d]` over the horizontal and vertical pairs.
fn difference_rms(x: &[f64], size: usize, d: usize) -> f64 {
    let (mut n, mut sum) = (0.0, 0.0);
    for_pairs(size, d, |p, q| {
        n += 1.0;
        sum += (x[p] - x[q]).powi(2);
    });
    (sum / f64::max(n, 1.0)).sqrt()
}

fn std_dev(x: &[f64]) -> f64 {
    let n = x.len() as f64;
    let m = x.iter().sum::<f64>() / n;
    (x.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n).sqrt()
}

/// The statistics of one `size²` crop of linear L, M, S planes (each `size²`, row-major).
pub fn measure_crop(l: &[f32], m: &[f32], s: &[f32], size: usize) -> SpatialStatistics {
    let nn = size * size;
    assert!(
        l.len() == nn && m.len() == nn && s.len() == nn,
        "measure_crop: planes of {}, {}, {} values for {size}²",
        l.len(),
        m.len(),
        s.len()
    );
    let mean = |p: &[f32]| p.iter().map(|&v| v as f64).sum::<f64>() / nn as f64;
    let (ml, mm, ms) = (mean(l), mean(m), mean(s));
    let eps = 1e-3 * (ml + mm).max(f64::MIN_POSITIVE);
    let lum: Vec<f64> = (0..nn).map(|p| l[p] as f64 + m[p] as f64 + eps).collect();
    let log_lum: Vec<f64> = lum.iter().map(|v| v.ln()).collect();
    let rg: Vec<f64> = (0..nn)
        .map(|p| (l[p] as f64 - m[p] as f64) / lum[p])
        .collect();
    let by: Vec<f64> = (0..nn).map(|p| s[p] as f64 / lum[p]).collect();
    let sd = [std_dev(&log_lum), std_dev(&rg), std_dev(&by)];
    let (srg, sby) = (sd[1].max(1e-12), sd[2].max(1e-12));
    let same = |d: usize| {
        let (mut n, mut hit) = (0usize, 0usize);
        for_pairs(size, d, |p, q| {
            let dist = (((rg[p] - rg[q]) / srg).powi(2) + ((by[p] - by[q]) / sby).powi(2)).sqrt();
            n += 1;
            hit += usize::from(dist < SAME_COLOUR_TOLERANCE);
        });
        hit as f64 / n.max(1) as f64
    };
    let mlm = ml + mm;
    let contrast =
        |f: &dyn Fn(usize) -> f64| -> Vec<f32> { (0..nn).map(|p| f(p) as f32).collect() };
    let lum_c = contrast(&|p| (l[p] as f64 + m[p] as f64) / mlm - 1.0);
    let rg_c = contrast(&|p| l[p] as f64 / ml - m[p] as f64 / mm);
    let by_c = contrast(&|p| s[p] as f64 / ms - (l[p] as f64 + m[p] as f64) / mlm);
    let slope = |c: &[f32]| {
        let uniform = c.iter().all(|&v| v == c[0]);
        if uniform {
            f64::NAN
        } else {
            power_spectrum_slope(c, size, 4.0, 0.5)
        }
    };
    SpatialStatistics {
        log_luminance: DISTANCES_PX
            .iter()
            .map(|&d| autocorrelation(&log_lum, size, d))
            .collect(),
        red_green: DISTANCES_PX
            .iter()
            .map(|&d| autocorrelation(&rg, size, d))
            .collect(),
        blue_yellow: DISTANCES_PX
            .iter()
            .map(|&d| autocorrelation(&by, size, d))
            .collect(),
        same_colour: DISTANCES_PX.iter().map(|&d| same(d)).collect(),
        spectral_slopes: [slope(&lum_c), slope(&rg_c), slope(&by_c)],
        contrast_sd: sd,
        red_green_difference_rms: DISTANCES_PX
            .iter()
            .map(|&d| difference_rms(&rg, size, d))
            .collect(),
    }
}

/// The mean statistics of the non-overlapping `CROP_PX` crops of `(≥ 3, h, w)` planes whose
/// first three are linear L, M, S. `None` when the image is smaller than one crop.
pub fn measure_image(planes: &[f32], h: usize, w: usize) -> Option<SpatialStatistics> {
    let c = CROP_PX;
    assert!(
        planes.len() >= 3 * h * w,
        "measure_image: planes shorter than 3 × {h} × {w}"
    );
    let crop = |plane: usize, y0: usize, x0: usize| -> Vec<f32> {
        let base = &planes[plane * h * w..(plane + 1) * h * w];
        (0..c)
            .flat_map(|y| {
                base[(y0 + y) * w + x0..(y0 + y) * w + x0 + c]
                    .iter()
                    .copied()
            })
            .collect()
    };
    let all: Vec<SpatialStatistics> = (0..h / c)
        .flat_map(|i| (0..w / c).map(move |j| (i * c, j * c)))
        .map(|(y0, x0)| measure_crop(&crop(0, y0, x0), &crop(1, y0, x0), &crop(2, y0, x0), c))
        .collect();
    (!all.is_empty()).then(|| SpatialStatistics::mean(&all))
}

#[cfg(test)]
mod tests;
