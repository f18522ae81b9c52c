//! Spectral tables: named columns of values sampled on a wavelength axis.
//!
//! File format (the one of every table in `data/`, see `data/README.md`):
//! - lines starting with `#` are comments (line 1 holds the provenance statement);
//! - the first other line is the header; its first field must be `wavelength_nm`;
//! - every further non-empty line holds one wavelength (nm) and one number per column, separated
//!   by commas; wavelengths strictly increase; every row has as many fields as the header.
//!
//! Layout: `values[c][i]` is column `c` at `wavelengths_nm[i]` (column-major: each spectrum is one
//! contiguous `Vec`). Interpolation and resampling are linear in wavelength.
//!
//! Non-finite numbers (`NaN`, `inf`) are parse errors, except through
//! [`SpectralTable::parse_allowing_nan`], which exists for the one embedded table that marks
//! undefined values with `NaN` (the CIE 2006 S-cone absorbance above 615 nm).

use std::path::Path;

use crate::error::{ColorimetryError, Result};
use crate::grid::WavelengthGrid;

/// Tolerance (nm) when checking that a table covers a requested wavelength.
const COVER_TOL_NM: f64 = 1e-9;

/// Named spectra sampled on a common, strictly increasing wavelength axis.
#[derive(Debug, Clone, PartialEq)]
pub struct SpectralTable {
    /// Table name (file name or path), used in error messages.
    pub name: String,
    /// Wavelengths, nm, strictly increasing.
    pub wavelengths_nm: Vec<f64>,
    /// Column names (without the wavelength column).
    pub columns: Vec<String>,
    /// One `Vec` per column, each as long as `wavelengths_nm`.
    pub values: Vec<Vec<f64>>,
}

impl SpectralTable {
    /// Parse CSV text (format in the module docs). `name` names the table in errors.
    pub fn parse(name: &str, text: &str) -> Result<SpectralTable> {
        parse_impl(name, text, false)
    }

    /// Like [`SpectralTable::parse`] but accepts `NaN` values (not `inf`).
    pub fn parse_allowing_nan(name: &str, text: &str) -> Result<SpectralTable> {
        parse_impl(name, text, true)
    }

    /// Read and parse a CSV file (a user's own spectra). The table is named by the path.
    pub fn from_csv_file(path: impl AsRef<Path>) -> Result<SpectralTable> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ColorimetryError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&path.display().to_string(), &text)
    }

    /// Build a table from parts, with the same checks as parsing.
    pub fn new(
        name: &str,
        wavelengths_nm: Vec<f64>,
        columns: Vec<String>,
        values: Vec<Vec<f64>>,
    ) -> Result<SpectralTable> {
        WavelengthGrid::new(wavelengths_nm.clone()).map_err(|e| ColorimetryError::Parse {
            file: name.into(),
            line: 0,
            field: "wavelength_nm".into(),
            message: e.to_string(),
        })?;
        if columns.len() != values.len() {
            return Err(ColorimetryError::Parse {
                file: name.into(),
                line: 0,
                field: "header".into(),
                message: format!(
                    "{} column names for {} columns",
                    columns.len(),
                    values.len()
                ),
            });
        }
        for (c, v) in columns.iter().zip(&values) {
            if v.len() != wavelengths_nm.len() {
                return Err(ColorimetryError::Parse {
                    file: name.into(),
                    line: 0,
                    field: c.clone(),
                    message: format!(
                        "{} values for {} wavelengths",
                        v.len(),
                        wavelengths_nm.len()
                    ),
                });
            }
        }
        Ok(SpectralTable {
            name: name.into(),
            wavelengths_nm,
            columns,
            values,
        })
    }

    /// Number of wavelengths.
    pub fn n_wavelengths(&self) -> usize {
        self.wavelengths_nm.len()
    }

    /// The wavelength axis as a grid.
    pub fn grid(&self) -> WavelengthGrid {
        WavelengthGrid::new(self.wavelengths_nm.clone()).expect("table axis was validated")
    }

    /// Index of a column by name.
    pub fn column_index(&self, column: &str) -> Result<usize> {
        self.columns
            .iter()
            .position(|c| c == column)
            .ok_or_else(|| ColorimetryError::MissingColumn {
                table: self.name.clone(),
                column: column.into(),
                available: abbreviate(&self.columns),
            })
    }

    /// The values of a column by name.
    pub fn column(&self, column: &str) -> Result<&[f64]> {
        Ok(&self.values[self.column_index(column)?])
    }

    /// Column `column` linearly interpolated at `wavelength_nm`. Error if the wavelength lies
    /// outside the table.
    pub fn interpolate(&self, column: &str, wavelength_nm: f64) -> Result<f64> {
        let c = self.column_index(column)?;
        self.check_covers(wavelength_nm, wavelength_nm)?;
        Ok(interp_linear(
            &self.wavelengths_nm,
            &self.values[c],
            wavelength_nm,
        ))
    }

    /// Column index `c` interpolated at `wavelength_nm`, or `None` outside the table. No
    /// allocation; for inner loops.
    pub fn interpolate_index(&self, c: usize, wavelength_nm: f64) -> Option<f64> {
        let w = &self.wavelengths_nm;
        if wavelength_nm < w[0] - COVER_TOL_NM || wavelength_nm > w[w.len() - 1] + COVER_TOL_NM {
            return None;
        }
        Some(interp_linear(w, &self.values[c], wavelength_nm))
    }

    /// All columns linearly resampled on `grid`. Error naming this table if the grid reaches
    /// outside the table's wavelength range (no extrapolation).
    pub fn resample(&self, grid: &WavelengthGrid) -> Result<SpectralTable> {
        self.check_covers(grid.min_nm(), grid.max_nm())?;
        let values = self
            .values
            .iter()
            .map(|col| {
                grid.as_slice()
                    .iter()
                    .map(|&w| interp_linear(&self.wavelengths_nm, col, w))
                    .collect()
            })
            .collect();
        Ok(SpectralTable {
            name: self.name.clone(),
            wavelengths_nm: grid.as_slice().to_vec(),
            columns: self.columns.clone(),
            values,
        })
    }

    /// One column resampled on `grid` (same rules as [`SpectralTable::resample`]).
    pub fn column_on(&self, column: &str, grid: &WavelengthGrid) -> Result<Vec<f64>> {
        let c = self.column_index(column)?;
        self.check_covers(grid.min_nm(), grid.max_nm())?;
        Ok(grid
            .as_slice()
            .iter()
            .map(|&w| interp_linear(&self.wavelengths_nm, &self.values[c], w))
            .collect())
    }

    /// A table holding only the named columns, in the given order.
    pub fn select(&self, columns: &[&str]) -> Result<SpectralTable> {
        let mut values = Vec::with_capacity(columns.len());
        for c in columns {
            values.push(self.column(c)?.to_vec());
        }
        Ok(SpectralTable {
            name: self.name.clone(),
            wavelengths_nm: self.wavelengths_nm.clone(),
            columns: columns.iter().map(|c| c.to_string()).collect(),
            values,
        })
    }

    /// Error unless `[lo_nm, hi_nm]` lies inside the table's wavelength range.
    pub fn check_covers(&self, lo_nm: f64, hi_nm: f64) -> Result<()> {
        let w = &self.wavelengths_nm;
        let (t0, t1) = (w[0], w[w.len() - 1]);
        if lo_nm < t0 - COVER_TOL_NM || hi_nm > t1 + COVER_TOL_NM || !(lo_nm.is_finite()) {
            return Err(ColorimetryError::NotCovered {
                table: self.name.clone(),
                table_min_nm: t0,
                table_max_nm: t1,
                requested_min_nm: lo_nm,
                requested_max_nm: hi_nm,
            });
        }
        Ok(())
    }
}

/// Linear interpolation of `(xs, ys)` at `x`; `x` is clamped to the axis ends.
pub fn interp_linear(xs: &[f64], ys: &[f64], x: f64) -> f64 {
    let n = xs.len();
    if n == 1 || x <= xs[0] {
        return ys[0];
    }
    if x >= xs[n - 1] {
        return ys[n - 1];
    }
    let i = xs.partition_point(|&v| v <= x); // xs[i-1] <= x < xs[i]
    let (x0, x1) = (xs[i - 1], xs[i]);
    let t = (x - x0) / (x1 - x0);
    if t == 0.0 {
        ys[i - 1]
    } else {
        ys[i - 1] + t * (ys[i] - ys[i - 1])
    }
}

/// The `#` provenance line of a table text (first comment line, without the `# `).
pub fn provenance_line(text: &str) -> Option<&str> {
    text.lines()
        .map(str::trim)
        .find(|l| l.starts_with('#'))
        .map(|l| l.trim_start_matches('#').trim())
}

fn abbreviate(cols: &[String]) -> String {
    if cols.len() <= 12 {
        cols.join(", ")
    } else {
        format!("{}, … ({} in all)", cols[..10].join(", "), cols.len())
    }
}

fn parse_impl(name: &str, text: &str, allow_nan: bool) -> Result<SpectralTable> {
    let err = |line: usize, field: &str, message: String| ColorimetryError::Parse {
        file: name.into(),
        line,
        field: field.into(),
        message,
    };
    let mut header: Option<Vec<String>> = None;
    let mut wavelengths = Vec::new();
    let mut values: Vec<Vec<f64>> = Vec::new();
    for (idx, raw) in text.lines().enumerate() {
        let line_no = idx + 1;
        let line = raw.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let Some(cols) = &header else {
            if fields[0] != "wavelength_nm" {
                return Err(err(
                    line_no,
                    "header",
                    format!(
                        "first column must be `wavelength_nm`, found `{}`",
                        fields[0]
                    ),
                ));
            }
            if fields.len() < 2 {
                return Err(err(line_no, "header", "no data columns".into()));
            }
            let cols: Vec<String> = fields[1..].iter().map(|s| s.to_string()).collect();
            values = vec![Vec::new(); cols.len()];
            header = Some(cols);
            continue;
        };
        if fields.len() != cols.len() + 1 {
            return Err(err(
                line_no,
                "row",
                format!(
                    "{} fields, but the header has {} (ragged row)",
                    fields.len(),
                    cols.len() + 1
                ),
            ));
        }
        for (k, f) in fields.iter().enumerate() {
            let field = if k == 0 {
                "wavelength_nm"
            } else {
                &cols[k - 1]
            };
            let v: f64 = f
                .parse()
                .map_err(|_| err(line_no, field, format!("`{f}` is not a number")))?;
            let nan_ok = allow_nan && k > 0 && v.is_nan();
            if !v.is_finite() && !nan_ok {
                return Err(err(line_no, field, format!("`{f}` is not a finite number")));
            }
            if k == 0 {
                if let Some(&prev) = wavelengths.last() {
                    if v <= prev {
                        return Err(err(
                            line_no,
                            field,
                            format!("wavelength {v} nm does not increase (previous {prev} nm)"),
                        ));
                    }
                }
                wavelengths.push(v);
            } else {
                values[k - 1].push(v);
            }
        }
    }
    let Some(columns) = header else {
        return Err(err(0, "header", "no header line".into()));
    };
    if wavelengths.is_empty() {
        return Err(err(0, "row", "no data rows".into()));
    }
    Ok(SpectralTable {
        name: name.into(),
        wavelengths_nm: wavelengths,
        columns,
        values,
    })
}

#[cfg(test)]
mod tests;
