//! Hyperspectral cubes in MATLAB v7.3 `.mat` files (HDF5), as NTIRE 2022 / ARAD_1K ships them,
//! and in plain HDF5 files (`.h5`, `.hdf5`).
//!
//! Read through `hdf5-reader`, a pure-Rust HDF5 decoder (chunked and deflate-compressed datasets,
//! the 512-byte user block MATLAB puts before the HDF5 data). What is read:
//! - the cube: the dataset named [`MatOptions::cube`] (ARAD_1K: `cube`), rank 3, of
//!   single/double floats (taken as they are) or 8/16-bit unsigned integers (scaled by 1/255 and
//!   1/65 535 to [0, 1], as CAVE's 16-bit bands are);
//! - its band wavelengths, nm: [`MatOptions::bands_nm`] when given, else the dataset named
//!   [`MatOptions::bands`] (ARAD_1K: `bands`, 400:10:700, double), any shape holding one value
//!   per band, increasing or decreasing.
//!
//! Layout. MATLAB stores arrays column-major, so HDF5 sees a MATLAB array's dimensions reversed:
//! ARAD's 482 × 512 × 31 (rows × columns × bands) cube is the HDF5 dataset (31, 512, 482). A
//! file is read in MATLAB's order when the cube has a `MATLAB_class` attribute or the file
//! starts with MATLAB's header text, in the dataset's own row-major order otherwise. In that
//! order the bands are the last dimension (rows × columns × bands, MATLAB's and NumPy's usual
//! layout) or, failing that, the first (bands × rows × columns); the band count comes from the
//! wavelengths. Output: a [`SpectralImage`] `(bands, rows, columns)`, row 0 the top row of the
//! MATLAB array (`cube(1, :, b)`), on the file's own wavelengths; [`read_scene_mat`] checks every
//! value (finite, ≥ 0) and resamples onto the eye's grid with [`SpectralImage::resample`], the
//! code the OpenEXR reader uses.
//!
//! Every error is one line naming the file ([`RetinaError::SceneFile`], [`RetinaError::Io`],
//! [`RetinaError::Radiance`], [`RetinaError::GridNotCovering`]): not HDF5 (a MATLAB v5 file
//! says so), truncated (shorter than its superblock declares) or corrupt, no cube dataset (the datasets found are listed), a cube that
//! is not rank 3 or whose dimensions do not match the band count, an unsupported element type.

use std::path::Path;

use colorimetry::WavelengthGrid;
use hdf5_reader::{Dataset, Datatype, Hdf5File, OpenOptions};
use serde::{Deserialize, Serialize};

use super::exr_io::MAX_EXR_VALUES;
use super::SpectralImage;
use crate::error::{Result, RetinaError};

/// Where a `.mat` / HDF5 file keeps its cube and its band wavelengths (module docs).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct MatOptions {
    /// Name (HDF5 path) of the cube dataset; ARAD_1K: `cube`.
    pub cube: String,
    /// Name of the dataset of band wavelengths, nm; ARAD_1K: `bands`.
    pub bands: String,
    /// Band wavelengths, nm, one per band; when given they replace the file's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bands_nm: Option<Vec<f64>>,
}

impl Default for MatOptions {
    /// ARAD_1K's names: `cube` and `bands`.
    fn default() -> Self {
        MatOptions {
            cube: "cube".into(),
            bands: "bands".into(),
            bands_nm: None,
        }
    }
}

/// Read a cube (module docs) on the file's own wavelengths.
pub fn read_spectral_mat(path: impl AsRef<Path>, options: &MatOptions) -> Result<SpectralImage> {
    let path = path.as_ref();
    let (file, matlab_header) = open(path)?;
    let cube = file.dataset(&options.cube).map_err(|_| {
        let found = dataset_names(&file);
        RetinaError::scene_file(
            path,
            format!(
                "no dataset `{}` (datasets found: {found}); name the cube with [retina.scenes.mat] \
                 cube = \"…\"",
                options.cube
            ),
        )
    })?;
    let column_major = matlab_header || cube.attribute("MATLAB_class").is_ok();
    let wavelengths = band_wavelengths(&file, path, options)?;
    let dims: Vec<usize> = cube.shape().iter().map(|&d| d as usize).collect();
    let [d0, d1, d2] = dims[..] else {
        return Err(RetinaError::scene_file(
            path,
            format!(
                "cube `{}` has {} dimensions {dims:?}; a spectral cube has 3 (rows × columns × \
                 bands in MATLAB)",
                options.cube,
                dims.len()
            ),
        ));
    };
    let nb = wavelengths.len();
    let Some(axes) = CubeAxes::find([d0, d1, d2], nb, column_major) else {
        let own = if column_major {
            [d2, d1, d0]
        } else {
            [d0, d1, d2]
        };
        return Err(RetinaError::scene_file(
            path,
            format!(
                "cube `{}` is {own:?} ({} order) and neither its last nor its first dimension \
                 is the {nb} bands of its wavelengths",
                options.cube,
                if column_major { "MATLAB" } else { "row-major" }
            ),
        ));
    };
    let total = d0.saturating_mul(d1).saturating_mul(d2);
    if total > MAX_EXR_VALUES || total == 0 {
        return Err(RetinaError::scene_file(
            path,
            format!(
                "cube `{}` holds {total} values; 1 to {MAX_EXR_VALUES} are read",
                options.cube
            ),
        ));
    }
    let values = read_f32(&cube, path, &options.cube)?;
    let mut img = axes.gather(&values, [d0, d1, d2]);
    set_grid(&mut img, wavelengths, path)?;
    Ok(img)
}

/// The file as HDF5, and whether it starts with MATLAB's header text. Errors: unreadable, not
/// HDF5 (a MATLAB v5 file named as such), shorter than its superblock declares.
fn open(path: &Path) -> Result<(Hdf5File, bool)> {
    let bytes = std::fs::read(path).map_err(|e| RetinaError::io(path, e))?;
    let matlab_header = bytes.starts_with(b"MATLAB");
    let v5 = bytes.starts_with(b"MATLAB 5.0");
    let len = bytes.len() as u64;
    let file = Hdf5File::from_vec_with_options(bytes, OpenOptions::default()).map_err(|e| {
        let what = if v5 {
            "a MATLAB v5 MAT-file, not v7.3 (HDF5); save it again with save(..., '-v7.3')".into()
        } else {
            format!("not a readable HDF5 / MATLAB v7.3 file ({e})")
        };
        RetinaError::scene_file(path, what)
    })?;
    // libhdf5 records the end of file counting the user block (7 607 for a 7 607-byte file
    // behind 512 bytes); a writer counting from the superblock records less, never more.
    let declared = file.superblock().eof_address;
    if len < declared {
        return Err(RetinaError::scene_file(
            path,
            format!("truncated: {len} bytes of the {declared} its HDF5 superblock declares"),
        ));
    }
    Ok((file, matlab_header))
}

/// The band wavelengths, nm: from the options, else from the file's bands dataset.
fn band_wavelengths(file: &Hdf5File, path: &Path, options: &MatOptions) -> Result<Vec<f64>> {
    if let Some(b) = &options.bands_nm {
        return Ok(b.clone());
    }
    let ds = file.dataset(&options.bands).map_err(|_| {
        RetinaError::scene_file(
            path,
            format!(
                "no dataset `{}` of band wavelengths (datasets found: {}); give them with \
                 [retina.scenes.mat] bands_nm = [400.0, 410.0, …]",
                options.bands,
                dataset_names(file)
            ),
        )
    })?;
    read_f64(&ds, path, &options.bands)
}

/// Read a cube as a scene's radiance onto `grid` (the grid of the cone sensitivities): every
/// value finite and ≥ 0, then resampled with [`SpectralImage::resample`].
pub fn read_scene_mat(
    path: impl AsRef<Path>,
    options: &MatOptions,
    grid: &WavelengthGrid,
) -> Result<SpectralImage> {
    let path = path.as_ref();
    let img = read_spectral_mat(path, options)?;
    img.check_radiance(path)?;
    img.resample(grid, &path.display().to_string())
}

/// Which HDF5 axis holds the bands, the rows and the columns of a rank-3 cube.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct CubeAxes {
    band: usize,
    row: usize,
    col: usize,
}

impl CubeAxes {
    /// The axes of a cube of HDF5 dimensions `dims` with `nb` bands (module docs): in the
    /// array's own order (MATLAB's is HDF5's reversed), bands last, else first.
    fn find(dims: [usize; 3], nb: usize, column_major: bool) -> Option<CubeAxes> {
        // HDF5 axis of each dimension in the array's own order.
        let own = if column_major { [2, 1, 0] } else { [0, 1, 2] };
        if dims[own[2]] == nb {
            Some(CubeAxes {
                band: own[2],
                row: own[0],
                col: own[1],
            })
        } else if dims[own[0]] == nb {
            Some(CubeAxes {
                band: own[0],
                row: own[1],
                col: own[2],
            })
        } else {
            None
        }
    }

    /// `(bands, rows, cols)` planar f32 from the row-major HDF5 values.
    fn gather(&self, values: &[f32], dims: [usize; 3]) -> SpectralImage {
        let stride = [dims[1] * dims[2], dims[2], 1];
        let (nb, h, w) = (dims[self.band], dims[self.row], dims[self.col]);
        let (sb, sy, sx) = (stride[self.band], stride[self.row], stride[self.col]);
        let mut data = Vec::with_capacity(nb * h * w);
        for b in 0..nb {
            for y in 0..h {
                data.extend((0..w).map(|x| values[b * sb + y * sy + x * sx]));
            }
        }
        SpectralImage {
            grid: WavelengthGrid::default(),
            h,
            w,
            data,
        }
    }
}

/// Puts `wavelengths` on `img`, reversing the band order when they decrease.
fn set_grid(img: &mut SpectralImage, mut wavelengths: Vec<f64>, path: &Path) -> Result<()> {
    if wavelengths.len() > 1 && wavelengths[0] > wavelengths[1] {
        wavelengths.reverse();
        let hw = img.h * img.w;
        let planes: Vec<&[f32]> = img.data.chunks(hw).rev().collect();
        img.data = planes.concat();
    }
    img.grid = WavelengthGrid::new(wavelengths)
        .map_err(|e| RetinaError::scene_file(path, format!("band wavelengths: {e}")))?;
    Ok(())
}

/// Names of the datasets at the file's root, comma-separated (or `none`).
fn dataset_names(file: &Hdf5File) -> String {
    match file.root_group().and_then(|g| g.member_names()) {
        Ok((_, names)) if !names.is_empty() => names.join(", "),
        _ => "none".into(),
    }
}

/// The element type of a dataset, for error messages.
fn type_name(dtype: &Datatype) -> String {
    match dtype {
        Datatype::FloatingPoint { size, .. } => format!("{}-bit float", 8 * size),
        Datatype::FixedPoint { size, signed, .. } => {
            format!("{}-bit {}", 8 * size, if *signed { "int" } else { "uint" })
        }
        other => format!("{other:?}")
            .split_whitespace()
            .next()
            .unwrap_or("")
            .into(),
    }
}

/// A dataset's values as f32 (module docs: floats as they are, u8 and u16 scaled to [0, 1]).
fn read_f32(ds: &Dataset, path: &Path, name: &str) -> Result<Vec<f32>> {
    let fail = |e: hdf5_reader::error::Error| {
        RetinaError::scene_file(path, format!("dataset `{name}` cannot be read ({e})"))
    };
    let n = ds.num_elements().map_err(fail)? as usize;
    match ds.dtype() {
        Datatype::FloatingPoint { size: 4, .. } => {
            let mut v = vec![0.0f32; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v)
        }
        Datatype::FloatingPoint { size: 8, .. } => {
            let mut v = vec![0.0f64; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v.into_iter().map(|x| x as f32).collect())
        }
        Datatype::FixedPoint {
            size: 1,
            signed: false,
            ..
        } => {
            let mut v = vec![0u8; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v.into_iter().map(|x| x as f32 / 255.0).collect())
        }
        Datatype::FixedPoint {
            size: 2,
            signed: false,
            ..
        } => {
            let mut v = vec![0u16; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v.into_iter().map(|x| x as f32 / 65535.0).collect())
        }
        other => Err(RetinaError::scene_file(
            path,
            format!(
                "dataset `{name}` holds {} values; a cube is single, double, uint8 or uint16",
                type_name(other)
            ),
        )),
    }
}

/// A small dataset (band wavelengths) as f64: single or double floats.
fn read_f64(ds: &Dataset, path: &Path, name: &str) -> Result<Vec<f64>> {
    let fail = |e: hdf5_reader::error::Error| {
        RetinaError::scene_file(path, format!("dataset `{name}` cannot be read ({e})"))
    };
    let n = ds.num_elements().map_err(fail)? as usize;
    if n > 1 << 16 {
        return Err(RetinaError::scene_file(
            path,
            format!("dataset `{name}` holds {n} values, not one wavelength per band"),
        ));
    }
    match ds.dtype() {
        Datatype::FloatingPoint { size: 8, .. } => {
            let mut v = vec![0.0f64; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v)
        }
        Datatype::FloatingPoint { size: 4, .. } => {
            let mut v = vec![0.0f32; n];
            ds.read_into(&mut v).map_err(fail)?;
            Ok(v.into_iter().map(f64::from).collect())
        }
        other => Err(RetinaError::scene_file(
            path,
            format!(
                "dataset `{name}` holds {} values; band wavelengths are single or double floats, nm",
                type_name(other)
            ),
        )),
    }
}

#[cfg(test)]
mod tests;
