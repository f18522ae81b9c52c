//! RGB photographs as scenes: through a simulated display (paper) or the sRGB → cone matrix
//! (official).
//!
//! - [`RgbImage::read_png`]: an 8- or 16-bit PNG (grey, grey+alpha, RGB, RGBA or palette; alpha
//!   ignored), sRGB-decoded to linear RGB in [0, 1], planar `(3, h, w)` f32.
//! - [`Display`] (paper S-02: "simulating a projector with specific SPDs for the R, G and B
//!   channels", Cottaris et al. 2019): each primary is a Gaussian band of fixed width (σ = 15,
//!   25, 12 nm for R, G, B, typical of LCD colour filters) plus a flat leakage floor; the band
//!   centre and the floor are fitted so that the primary's CIE 1931 chromaticity is the sRGB
//!   primary's (R 0.64, 0.33; G 0.30, 0.60; B 0.15, 0.06; IEC 61966-2-1) — a pure band cannot
//!   reach sRGB red, which lies inside the straight red end of the spectral locus. The three
//!   intensities are set
//!   so that RGB (1, 1, 1) has the D65 white's XYZ with Y = 1. A pixel's spectrum is
//!   `Σ_c rgb_c · P_c(λ)` — every such scene spans exactly 3 spectral dimensions.
//! - [`class_planes_by_matrix`] (authors' code, docs/references.md#colour-transforms): class excitations = linear RGB · `rgb_to_cone`
//!   of `colorimetry::cone_rgb::ConeRgb` (least-squares fit of the fundamentals from CIE XYZ,
//!   composed with sRGB → XYZ). No spectra involved.

use std::path::Path;

use colorimetry::cie::{xyz_to_xy, CieObserver};
use colorimetry::cone_rgb::ConeRgb;
use colorimetry::linalg::mat3_inverse;
use colorimetry::srgb::inverse_oetf;
use colorimetry::WavelengthGrid;

use super::png_io::decode_png;
use super::SpectralImage;
use crate::error::{Result, RetinaError};

/// sRGB primaries' chromaticities (IEC 61966-2-1), R, G, B.
pub const SRGB_PRIMARIES_XY: [[f64; 2]; 3] = [[0.64, 0.33], [0.30, 0.60], [0.15, 0.06]];
/// D65 white XYZ with Y = 1 (IEC 61966-2-1 white point x 0.3127, y 0.3290).
pub const D65_WHITE_XYZ: [f64; 3] = [0.3127 / 0.3290, 1.0, (1.0 - 0.3127 - 0.3290) / 0.3290];

/// A linear-RGB image, planar `(3, h, w)`.
#[derive(Debug, Clone, PartialEq)]
pub struct RgbImage {
    /// Rows.
    pub h: usize,
    /// Columns.
    pub w: usize,
    /// Linear sRGB, `(3, h, w)`.
    pub linear: Vec<f32>,
}

impl RgbImage {
    /// Read and linearise a PNG (module docs).
    pub fn read_png(path: impl AsRef<Path>) -> Result<RgbImage> {
        let path = path.as_ref();
        let png = decode_png(path)?;
        let (h, w, max) = (png.h, png.w, png.full_scale as f64);
        let mut linear = vec![0.0f32; 3 * h * w];
        for y in 0..h {
            for x in 0..w {
                for c in 0..3 {
                    let v = inverse_oetf(png.colour(y, x, c) as f64 / max);
                    linear[c * h * w + y * w + x] = v as f32;
                }
            }
        }
        Ok(RgbImage { h, w, linear })
    }
}

/// Band widths σ (nm) of the display primaries R, G, B (module docs).
pub const DISPLAY_BAND_WIDTHS_NM: [f64; 3] = [15.0, 25.0, 12.0];

/// `exp(−(λ − μ)²/(2σ²)) + floor` on `wavelengths`.
fn band(wavelengths: &[f64], centre_nm: f64, width_nm: f64, floor: f64) -> Vec<f64> {
    wavelengths
        .iter()
        .map(|&l| (-(l - centre_nm).powi(2) / (2.0 * width_nm * width_nm)).exp() + floor)
        .collect()
}

/// A simulated three-primary display (module docs).
#[derive(Debug, Clone, PartialEq)]
pub struct Display {
    /// The grid of the primaries.
    pub grid: WavelengthGrid,
    /// Radiance of each primary at unit drive, on the grid.
    pub primaries: [Vec<f64>; 3],
    /// Fitted band centres, nm.
    pub centres_nm: [f64; 3],
    /// Band widths (σ), nm.
    pub widths_nm: [f64; 3],
    /// Fitted leakage floors, relative to the band's peak.
    pub floors: [f64; 3],
}

impl Display {
    /// The sRGB-like display on `grid` (module docs). Error if the grid leaves 360–830 nm or a
    /// primary cannot be fitted.
    pub fn srgb_like(grid: &WavelengthGrid) -> Result<Display> {
        let fine = WavelengthGrid::range(380.0, 780.0, 1.0)?;
        let fine_obs = CieObserver::cie1931(&fine)?;
        let starts = [[610.0, 0.01], [540.0, 0.02], [462.0, 0.005]];
        let mut centres = [0.0; 3];
        let mut floors = [0.0; 3];
        for p in 0..3 {
            let target = SRGB_PRIMARIES_XY[p];
            let sigma = DISPLAY_BAND_WIDTHS_NM[p];
            let [mut mu, mut floor] = starts[p];
            let f = |mu: f64, floor: f64| {
                let xy =
                    xyz_to_xy(fine_obs.xyz_of_radiance(&band(fine.as_slice(), mu, sigma, floor)));
                [xy[0] - target[0], xy[1] - target[1]]
            };
            for _ in 0..100 {
                let r = f(mu, floor);
                if r[0].hypot(r[1]) < 1e-12 {
                    break;
                }
                let (h_mu, h_fl) = (1e-5, 1e-7);
                let (a, b) = (f(mu + h_mu, floor), f(mu, floor + h_fl));
                let j = [
                    [(a[0] - r[0]) / h_mu, (b[0] - r[0]) / h_fl],
                    [(a[1] - r[1]) / h_mu, (b[1] - r[1]) / h_fl],
                ];
                let det = j[0][0] * j[1][1] - j[0][1] * j[1][0];
                if det.abs() < 1e-300 {
                    break;
                }
                let d_mu = (j[1][1] * r[0] - j[0][1] * r[1]) / det;
                let d_fl = (-j[1][0] * r[0] + j[0][0] * r[1]) / det;
                // Damped: at most 10 nm and a floor change of 0.05 per step.
                let step = 1.0f64
                    .min(10.0 / d_mu.abs().max(1e-12))
                    .min(0.05 / d_fl.abs().max(1e-12));
                mu = (mu - step * d_mu).clamp(400.0, 700.0);
                floor = (floor - step * d_fl).clamp(0.0, 1.0);
            }
            let r = f(mu, floor);
            if r[0].hypot(r[1]) > 1e-6 {
                return Err(RetinaError::setting(
                    "display primaries",
                    format!("could not fit sRGB primary {p} (chromaticity residual {r:?})"),
                ));
            }
            centres[p] = mu;
            floors[p] = floor;
        }
        let obs = CieObserver::cie1931(grid)?;
        let raw: Vec<Vec<f64>> = (0..3)
            .map(|p| {
                band(
                    grid.as_slice(),
                    centres[p],
                    DISPLAY_BAND_WIDTHS_NM[p],
                    floors[p],
                )
            })
            .collect();
        // Columns = XYZ of each primary; intensities a solve M·a = white.
        let xyz: Vec<[f64; 3]> = raw.iter().map(|s| obs.xyz_of_radiance(s)).collect();
        let m = [
            [xyz[0][0], xyz[1][0], xyz[2][0]],
            [xyz[0][1], xyz[1][1], xyz[2][1]],
            [xyz[0][2], xyz[1][2], xyz[2][2]],
        ];
        let inv = mat3_inverse(&m).ok_or_else(|| {
            RetinaError::setting("display primaries", "primaries are linearly dependent")
        })?;
        let a: Vec<f64> = (0..3)
            .map(|i| (0..3).map(|j| inv[i][j] * D65_WHITE_XYZ[j]).sum())
            .collect();
        let primaries = [0, 1, 2].map(|p| raw[p].iter().map(|v| v * a[p]).collect::<Vec<f64>>());
        Ok(Display {
            grid: grid.clone(),
            primaries,
            centres_nm: centres,
            widths_nm: DISPLAY_BAND_WIDTHS_NM,
            floors,
        })
    }

    /// The spectral image a display shows for a linear-RGB image.
    pub fn spectral_image(&self, rgb: &RgbImage) -> SpectralImage {
        let hw = rgb.h * rgb.w;
        let mut img = SpectralImage::zeros(self.grid.clone(), rgb.h, rgb.w);
        for l in 0..self.grid.len() {
            let out = &mut img.data[l * hw..(l + 1) * hw];
            for c in 0..3 {
                let p = self.primaries[c][l] as f32;
                for (o, &v) in out.iter_mut().zip(&rgb.linear[c * hw..(c + 1) * hw]) {
                    *o += p * v;
                }
            }
        }
        img
    }
}

/// Class excitations by the official matrix (module docs): `(k, h, w)`.
pub fn class_planes_by_matrix(rgb: &RgbImage, cone_rgb: &ConeRgb) -> Vec<f32> {
    let (hw, k) = (rgb.h * rgb.w, cone_rgb.n_classes);
    let mut out = vec![0.0f32; k * hw];
    for c in 0..k {
        for r in 0..3 {
            let m = cone_rgb.rgb_to_cone[r * k + c] as f32;
            for (o, &v) in out[c * hw..(c + 1) * hw]
                .iter_mut()
                .zip(&rgb.linear[r * hw..(r + 1) * hw])
            {
                *o += m * v;
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use colorimetry::{sensitivities, ConeClass, ConeTemplate};

    fn data_image(name: &str) -> std::path::PathBuf {
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("data")
            .join(name)
    }

    #[test]
    fn display_primaries_have_srgb_chromaticities_and_d65_white() {
        let g = WavelengthGrid::default();
        let d = Display::srgb_like(&g).unwrap();
        eprintln!(
            "display centres {:?} nm, floors {:?}",
            d.centres_nm, d.floors
        );
        let obs = CieObserver::cie1931(&g).unwrap();
        let white: Vec<f64> = (0..g.len())
            .map(|l| (0..3).map(|c| d.primaries[c][l]).sum())
            .collect();
        let w = obs.xyz_of_radiance(&white);
        for (a, b) in w.iter().zip(D65_WHITE_XYZ) {
            assert!((a - b).abs() < 1e-9, "{w:?}");
        }
        // On the coarse grid the chromaticities stay close to sRGB's (fitted at 1 nm).
        for p in 0..3 {
            let xy = xyz_to_xy(obs.xyz_of_radiance(&d.primaries[p]));
            assert!(
                (xy[0] - SRGB_PRIMARIES_XY[p][0]).abs() < 0.02,
                "{p}: {xy:?}"
            );
            assert!(
                (xy[1] - SRGB_PRIMARIES_XY[p][1]).abs() < 0.02,
                "{p}: {xy:?}"
            );
        }
    }

    #[test]
    fn official_matrix_rows_and_white() {
        // Authors' code, docs/references.md#colour-transforms: rows R, G, B of linear sRGB → LMS and the LMS of the sRGB white.
        let g = WavelengthGrid::official_1nm();
        let f = sensitivities(&ConeClass::lms(), &ConeTemplate::default(), &g).unwrap();
        let m = ConeRgb::fit(&f).unwrap();
        let want = [
            [0.247, 0.046, 0.018],
            [0.714, 0.748, 0.036],
            [0.122, 0.212, 0.466],
        ];
        for r in 0..3 {
            for c in 0..3 {
                assert!(
                    (m.rgb_to_cone[r * 3 + c] - want[r][c]).abs() < 0.005,
                    "{r},{c}"
                );
            }
        }
        let rgb = RgbImage {
            h: 1,
            w: 1,
            linear: vec![1.0, 1.0, 1.0],
        };
        let white = class_planes_by_matrix(&rgb, &m);
        for (a, b) in white.iter().zip([1.083, 1.006, 0.520]) {
            assert!((*a as f64 - b).abs() < 0.005, "{white:?}");
        }
    }

    #[test]
    fn png_photographs_decode_to_linear_rgb() {
        let img = RgbImage::read_png(data_image("astronaut.png")).unwrap();
        assert_eq!((img.h, img.w), (512, 512));
        assert!(img.linear.iter().all(|&v| (0.0..=1.0).contains(&v)));
        let mean: f32 = img.linear.iter().sum::<f32>() / img.linear.len() as f32;
        assert!(mean > 0.05 && mean < 0.6, "{mean}");
        // A file that exists but is not a PNG (JPEG magic bytes) is an error naming the file.
        let jpeg = std::env::temp_dir().join(format!("cv_not_png_{}.jpg", std::process::id()));
        std::fs::write(
            &jpeg,
            [0xFF, 0xD8, 0xFF, 0xE0, 0, 16, b'J', b'F', b'I', b'F', 0],
        )
        .unwrap();
        let e = RgbImage::read_png(&jpeg).unwrap_err();
        std::fs::remove_file(&jpeg).ok();
        assert!(e.to_string().contains("cv_not_png_"), "{e}");
    }
}
