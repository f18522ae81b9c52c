//! The projection of scenes onto a mosaic's classes (plus the reference L, M, S used for the
//! ground-truth sRGB), with each plane's white and the official sRGB matrices.
//!
//! Planes `0..k` are the mosaic's classes; the reference classes L 560, M 530, S 419 (under the
//! retina's template) are shared with them when present and appended as `ref_L`, `ref_M`,
//! `ref_S` otherwise. `white[c]` is plane c's response to the sRGB white (1, 1, 1) through the
//! official least-squares matrix (`colorimetry::cone_rgb`; L ≈ 1.083, M ≈ 1.006, S ≈ 0.520),
//! the target of the per-image white balance (authors' code, docs/references.md#scenes).

use colorimetry::cone_rgb::ConeRgb;
use colorimetry::{sensitivities, ConeClass, ConeTemplate, WavelengthGrid};

use super::{ClassPlanes, Projector, SpectralImage};
use crate::error::Result;

/// The projection of scenes onto a mosaic's classes, and the whites and matrices around it.
#[derive(Debug, Clone)]
pub struct SceneProjection {
    /// Sensitivity grid.
    pub grid: WavelengthGrid,
    /// One class per plane: the k mosaic classes, then any reference class they lack.
    pub plane_classes: Vec<ConeClass>,
    /// Number of mosaic classes.
    pub k: usize,
    /// Plane indices of the reference L, M, S.
    pub reference_lms: [usize; 3],
    /// Spectra → planes.
    pub projector: Projector,
    /// Linear sRGB ↔ planes (official matrix path) for all planes.
    pub cone_rgb: ConeRgb,
    /// Response of each plane to the sRGB white (1, 1, 1).
    pub white: Vec<f64>,
    /// Reference L, M, S → linear sRGB, row-major (3 × 3): `rgb = lms · m`.
    pub lms_to_rgb: [[f64; 3]; 3],
}

impl SceneProjection {
    /// For the mosaic `classes` under `template` on `grid`.
    pub fn new(
        classes: &[ConeClass],
        template: &ConeTemplate,
        grid: &WavelengthGrid,
    ) -> Result<Self> {
        let k = classes.len();
        let (plane_classes, reference_lms) = Self::planes_for(classes);
        let f = sensitivities(&plane_classes, template, grid)?;
        let projector = Projector::cones(&f);
        let cone_rgb = ConeRgb::fit(&f)?;
        let white = (0..plane_classes.len())
            .map(|c| {
                (0..3)
                    .map(|r| cone_rgb.rgb_to_cone[r * plane_classes.len() + c])
                    .sum()
            })
            .collect();
        let ref_f = sensitivities(&ConeClass::lms(), template, grid)?;
        let ref_rgb = ConeRgb::fit(&ref_f)?;
        let mut lms_to_rgb = [[0.0; 3]; 3];
        for (c, row) in lms_to_rgb.iter_mut().enumerate() {
            for (r, v) in row.iter_mut().enumerate() {
                *v = ref_rgb.cone_to_rgb[c * 3 + r];
            }
        }
        Ok(SceneProjection {
            grid: grid.clone(),
            plane_classes,
            k,
            reference_lms,
            projector,
            cone_rgb,
            white,
            lms_to_rgb,
        })
    }

    /// The planes a scene is projected onto for the mosaic `classes`: its classes, then the
    /// reference L, M, S that are not among them (for ground truth); and where each reference
    /// plane is.
    pub fn planes_for(classes: &[ConeClass]) -> (Vec<ConeClass>, [usize; 3]) {
        let mut plane_classes = classes.to_vec();
        let mut reference_lms = [0usize; 3];
        for (r, rc) in ConeClass::lms().into_iter().enumerate() {
            reference_lms[r] = match plane_classes.iter().position(|c| *c == rc) {
                Some(i) => i,
                None => {
                    plane_classes.push(ConeClass::custom(format!("ref_{}", rc.name), rc.peak_nm));
                    plane_classes.len() - 1
                }
            };
        }
        (plane_classes, reference_lms)
    }

    /// Number of planes.
    pub fn n_planes(&self) -> usize {
        self.plane_classes.len()
    }

    /// Project a spectral image (on [`SceneProjection::grid`]).
    pub fn project(&self, img: &SpectralImage) -> ClassPlanes {
        self.wrap(img.h, img.w, self.projector.project_image(img))
    }

    /// Wrap `(n_planes, h, w)` data.
    pub fn wrap(&self, h: usize, w: usize, planes: Vec<f32>) -> ClassPlanes {
        assert_eq!(
            planes.len(),
            self.n_planes() * h * w,
            "SceneProjection::wrap: shape"
        );
        ClassPlanes {
            h,
            w,
            k: self.k,
            n_planes: self.n_planes(),
            planes,
            reference_lms: self.reference_lms,
        }
    }
}
