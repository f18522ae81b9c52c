//! Scenes: spectral radiance images, and their projection onto cone classes.
//!
//! - [`SpectralImage`]: `(wavelengths, h, w)` planar f32 spectral radiance (relative units; a
//!   reflectance of 1 under an illuminant of luminance Y = 1 has Y = 1) on a [`WavelengthGrid`].
//! - [`Projector`]: the linear map from spectra to class excitations, `(k × wavelengths)`,
//!   `e_c = Σ_λ F_c(λ)·L(λ)·Δλ` with F the peak-1 sensitivities and Δλ the grid's quadrature
//!   weights (so the result does not depend on the grid spacing; CIE XYZ is projected the same
//!   way). Scenes are projected ONCE onto the mosaic's distinct classes (the map is linear), and
//!   the retina then works on class planes.
//! - [`ClassPlanes`]: a projected scene, `(k, h, w)` planar f32, with the reference L, M, S
//!   planes used for the ground-truth linear sRGB.
//!
//! Sources: [`dead_leaves`] (the default, synthetic, embedded data), [`exr_io`] (spectral
//! OpenEXR), [`mat_io`] (MATLAB v7.3 hyperspectral cubes such as NTIRE 2022 / ARAD_1K),
//! [`band_stack`] (one grey PNG per band, as CAVE ships its scenes), [`envi_io`] (ENVI cubes of
//! hyperspectral cameras),
//! [`rgb`] (photographs through a simulated display or the official matrix), [`tetra`]
//! (environments rich in tetrachromatic colours, paper S-07), all gathered in a [`pool`] of
//! tiles that training crops are drawn from. Scene files ([`sources`]: files, folders, globs)
//! are [`prepared`] once — projected onto the eye's classes, resized, white balanced — and
//! kept on disk in a [`plane_cache`].

pub mod band_stack;
pub mod dead_leaves;
pub mod envi_io;
pub mod exr_io;

#[cfg(test)]
mod fixture_pattern;
pub mod hue_sphere;
pub mod library;
pub mod mat_io;
pub mod plane_cache;
mod png_io;
pub mod pool;
pub mod prepared;
pub mod projection;
pub mod q_from_lms;
pub mod resize;
pub mod rgb;
pub mod sources;
pub mod statistics;
pub mod surfaces;
pub mod tetra;

use colorimetry::cie::CieObserver;
use colorimetry::{ConeFundamentals, WavelengthGrid};

use crate::error::{Result, RetinaError};

/// A spectral radiance image (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralImage {
    /// Wavelengths of the planes.
    pub grid: WavelengthGrid,
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// `(grid.len(), h, w)` planar.
    pub data: Vec<f32>,
}

impl SpectralImage {
    /// A zero image.
    pub fn zeros(grid: WavelengthGrid, h: usize, w: usize) -> Self {
        let n = grid.len() * h * w;
        SpectralImage {
            grid,
            h,
            w,
            data: vec![0.0; n],
        }
    }

    /// Plane of wavelength index `l`.
    pub fn plane(&self, l: usize) -> &[f32] {
        let hw = self.h * self.w;
        &self.data[l * hw..(l + 1) * hw]
    }

    /// The spectrum at pixel `(y, x)`.
    pub fn spectrum(&self, y: usize, x: usize) -> Vec<f32> {
        let hw = self.h * self.w;
        (0..self.grid.len())
            .map(|l| self.data[l * hw + y * self.w + x])
            .collect()
    }

    /// Every value must be finite and ≥ 0 (a radiance): otherwise an error naming `path`, the
    /// first bad pixel `(x, y)`, its wavelength and its value.
    pub fn check_radiance(&self, path: &std::path::Path) -> Result<()> {
        let (h, w) = (self.h, self.w);
        let plane = (h * w).max(1);
        match self.data.iter().position(|v| !(v.is_finite() && *v >= 0.0)) {
            None => Ok(()),
            Some(i) => Err(RetinaError::Radiance {
                path: path.to_path_buf(),
                message: format!(
                    "pixel (x {}, y {}) at {} nm is {}: radiance must be finite and ≥ 0",
                    (i % plane) % w.max(1),
                    (i % plane) / w.max(1),
                    self.grid.as_slice()[i / plane],
                    self.data[i]
                ),
            }),
        }
    }

    /// Linearly resample every pixel's spectrum onto `grid`. Error naming `source_name` if this
    /// image's wavelengths do not cover `grid`.
    pub fn resample(&self, grid: &WavelengthGrid, source_name: &str) -> Result<SpectralImage> {
        let have = self.grid.as_slice();
        let tol = 1e-6;
        if grid.min_nm() < self.grid.min_nm() - tol || grid.max_nm() > self.grid.max_nm() + tol {
            return Err(RetinaError::GridNotCovering {
                source_name: source_name.into(),
                have_min_nm: self.grid.min_nm(),
                have_max_nm: self.grid.max_nm(),
                need_min_nm: grid.min_nm(),
                need_max_nm: grid.max_nm(),
            });
        }
        if grid == &self.grid {
            return Ok(self.clone());
        }
        let hw = self.h * self.w;
        let mut out = SpectralImage::zeros(grid.clone(), self.h, self.w);
        for (l, &wl) in grid.as_slice().iter().enumerate() {
            let i = have
                .partition_point(|&v| v <= wl)
                .clamp(1, have.len().max(2) - 1);
            let (i0, i1) = if have.len() == 1 { (0, 0) } else { (i - 1, i) };
            let t = if i0 == i1 {
                0.0
            } else {
                ((wl - have[i0]) / (have[i1] - have[i0])).clamp(0.0, 1.0) as f32
            };
            let (a, b) = (self.plane(i0), self.plane(i1));
            for (o, (&p, &q)) in out.data[l * hw..(l + 1) * hw]
                .iter_mut()
                .zip(a.iter().zip(b))
            {
                // (1 − t)·p + t·q is exact at both ends (t = 0 or 1).
                *o = (1.0 - t) * p + t * q;
            }
        }
        Ok(out)
    }
}

/// Linear map spectra → k channels (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Projector {
    /// The grid the spectra must be on.
    pub grid: WavelengthGrid,
    /// Number of output channels.
    pub k: usize,
    /// `(k, grid.len())` row-major: `F_c(λ)·Δλ`.
    pub matrix: Vec<f32>,
}

impl Projector {
    /// Class excitations of the given fundamentals.
    pub fn cones(f: &ConeFundamentals) -> Projector {
        let (k, n) = (f.n_classes(), f.n_wavelengths());
        let dl = f.grid.weights_nm();
        let mut matrix = vec![0.0f32; k * n];
        for c in 0..k {
            for l in 0..n {
                matrix[c * n + l] = (f.get(l, c) * dl[l]) as f32;
            }
        }
        Projector {
            grid: f.grid.clone(),
            k,
            matrix,
        }
    }

    /// CIE 1931 XYZ (`Σ x̄·L·Δλ`, …), on `grid`.
    pub fn xyz(grid: &WavelengthGrid) -> Result<Projector> {
        let obs = CieObserver::cie1931(grid)?;
        let (n, dl) = (grid.len(), grid.weights_nm());
        let mut matrix = vec![0.0f32; 3 * n];
        for c in 0..3 {
            for l in 0..n {
                matrix[c * n + l] = (obs.cmf(c)[l] * dl[l]) as f32;
            }
        }
        Ok(Projector {
            grid: grid.clone(),
            k: 3,
            matrix,
        })
    }

    /// Project one spectrum (f64, on the grid) to k values.
    pub fn project_spectrum(&self, spectrum: &[f64]) -> Vec<f64> {
        let n = self.grid.len();
        assert_eq!(
            spectrum.len(),
            n,
            "Projector::project_spectrum: length vs grid"
        );
        (0..self.k)
            .map(|c| {
                (0..n)
                    .map(|l| self.matrix[c * n + l] as f64 * spectrum[l])
                    .sum()
            })
            .collect()
    }

    /// Project an image: `(k, h, w)` planar. Panics if the image is on another grid (resample it
    /// first with [`SpectralImage::resample`]).
    pub fn project_image(&self, img: &SpectralImage) -> Vec<f32> {
        assert_eq!(
            img.grid,
            self.grid,
            "Projector::project_image: image grid ({} wavelengths) differs from the projector's \
             ({})",
            img.grid.len(),
            self.grid.len()
        );
        let hw = img.h * img.w;
        let n = self.grid.len();
        let mut out = vec![0.0f32; self.k * hw];
        for c in 0..self.k {
            let o = &mut out[c * hw..(c + 1) * hw];
            for l in 0..n {
                let m = self.matrix[c * n + l];
                if m != 0.0 {
                    for (v, &s) in o.iter_mut().zip(img.plane(l)) {
                        *v += m * s;
                    }
                }
            }
        }
        out
    }
}

/// A scene projected onto the mosaic's classes (module docs).
///
/// Planes `0..k` are the mosaic's classes in mosaic order; the reference L, M, S planes for the
/// ground-truth sRGB are `reference_lms` (indices into the planes — shared with the class planes
/// when the mosaic has the reference classes, appended after them otherwise).
#[derive(Debug, Clone, PartialEq)]
pub struct ClassPlanes {
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// Number of mosaic classes k.
    pub k: usize,
    /// Total number of planes (k + appended reference planes).
    pub n_planes: usize,
    /// `(n_planes, h, w)` class excitations.
    pub planes: Vec<f32>,
    /// Plane indices of the reference L, M, S.
    pub reference_lms: [usize; 3],
}

impl ClassPlanes {
    /// Per-image white balance (authors' code, docs/references.md#scenes): each plane divided by its maximum over
    /// the image, then multiplied by that class's response to the sRGB white (1, 1, 1)
    /// (`white`, one value per plane). Planes whose maximum is ≤ 0 are left unchanged.
    pub fn white_balance(&mut self, white: &[f64]) {
        assert_eq!(
            white.len(),
            self.n_planes,
            "ClassPlanes::white_balance: {} whites for {} planes",
            white.len(),
            self.n_planes
        );
        let hw = self.h * self.w;
        for (plane, &wc) in self.planes.chunks_mut(hw).zip(white) {
            let max = plane.iter().copied().fold(f32::NEG_INFINITY, f32::max);
            if max > 0.0 {
                let g = (wc / max as f64) as f32;
                plane.iter_mut().for_each(|v| *v *= g);
            }
        }
    }

    /// The first value that is not finite, as (plane, x, y, value): what a radiance too large
    /// for `f32` sums (finite in the file, infinite once summed over wavelengths) leaves.
    pub fn first_non_finite(&self) -> Option<(usize, usize, usize, f32)> {
        let hw = (self.h * self.w).max(1);
        let i = self.planes.iter().position(|v| !v.is_finite())?;
        let w = self.w.max(1);
        Some((i / hw, (i % hw) % w, (i % hw) / w, self.planes[i]))
    }

    /// Plane `p`, `(h, w)`.
    pub fn plane(&self, p: usize) -> &[f32] {
        let hw = self.h * self.w;
        &self.planes[p * hw..(p + 1) * hw]
    }
}

#[cfg(test)]
pub(crate) mod tests;
