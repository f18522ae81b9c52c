//! Cone fundamentals: the table of each cone class's normalised sensitivity on a wavelength
//! grid ([`ConeFundamentals`]), and [`sensitivities`], which builds it from a template, the
//! lens and peak normalisation (conventions in the parent module's docs).

use super::*;

/// Cone sensitivities on a grid: `values[w * n_classes + c]`, each class peak 1.
#[derive(Debug, Clone, PartialEq)]
pub struct ConeFundamentals {
    /// The wavelength grid (rows).
    pub grid: WavelengthGrid,
    /// The classes (columns).
    pub classes: Vec<ConeClass>,
    /// Row-major `(grid.len() × classes.len())`.
    pub values: Vec<f64>,
}

impl ConeFundamentals {
    /// Number of classes.
    pub fn n_classes(&self) -> usize {
        self.classes.len()
    }
    /// Number of wavelengths.
    pub fn n_wavelengths(&self) -> usize {
        self.grid.len()
    }
    /// Sensitivity of class `c` at grid index `w`.
    pub fn get(&self, w: usize, c: usize) -> f64 {
        self.values[w * self.classes.len() + c]
    }
    /// All classes at grid index `w`.
    pub fn row(&self, w: usize) -> &[f64] {
        let k = self.classes.len();
        &self.values[w * k..(w + 1) * k]
    }
    /// Class `c` over the grid.
    pub fn column(&self, c: usize) -> Vec<f64> {
        (0..self.grid.len()).map(|w| self.get(w, c)).collect()
    }
    /// Index of the first class with this name.
    pub fn class_index(&self, name: &str) -> Option<usize> {
        self.classes.iter().position(|c| c.name == name)
    }
    /// Wavelength (nm) of class `c`'s maximum on the grid, refined by the vertex of the parabola
    /// through the maximum and its two neighbours (when both exist).
    pub fn effective_peak_nm(&self, c: usize) -> f64 {
        let col = self.column(c);
        let w = self.grid.as_slice();
        let i = (0..col.len())
            .max_by(|&a, &b| col[a].total_cmp(&col[b]))
            .expect("grid is non-empty");
        if i == 0 || i + 1 == col.len() {
            return w[i];
        }
        let (x0, x1, x2) = (w[i - 1], w[i], w[i + 1]);
        let (y0, y1, y2) = (col[i - 1], col[i], col[i + 1]);
        let d0 = (y1 - y0) / (x1 - x0);
        let d1 = (y2 - y1) / (x2 - x1);
        let curv = (d1 - d0) / (x2 - x0);
        if curv >= 0.0 {
            return x1;
        }
        // p(x) = y0 + d0·(x − x0) + curv·(x − x0)·(x − x1); p'(x) = 0 at the vertex.
        (0.5 * (x0 + x1) - d0 / (2.0 * curv)).clamp(x0, x2)
    }
    /// Cone excitations of a spectrum on the same grid: `Σ_w spectrum[w]·F[w, c]` (plain sum
    /// over samples, no Δλ, as the official pre-integration).
    ///
    /// # Panics
    /// If `spectrum.len() != n_wavelengths()`.
    pub fn excitations(&self, spectrum: &[f64]) -> Vec<f64> {
        let mut out = vec![0.0; self.n_classes()];
        self.excitations_into(spectrum, &mut out);
        out
    }
    /// [`ConeFundamentals::excitations`] into a caller buffer of length `n_classes()`.
    pub fn excitations_into(&self, spectrum: &[f64], out: &mut [f64]) {
        assert_eq!(
            spectrum.len(),
            self.n_wavelengths(),
            "ConeFundamentals::excitations: spectrum length {} vs grid length {}",
            spectrum.len(),
            self.n_wavelengths()
        );
        assert_eq!(
            out.len(),
            self.n_classes(),
            "excitations_into: output length"
        );
        out.fill(0.0);
        for (w, &s) in spectrum.iter().enumerate() {
            if s != 0.0 {
                for (o, &f) in out.iter_mut().zip(self.row(w)) {
                    *o += s * f;
                }
            }
        }
    }
}

/// Sensitivities of `classes` on `grid` with `template`, each normalised to peak 1.
///
/// Errors: the grid reaches outside the lens table (390–830 nm) or the Stockman–Sharpe table;
/// a Stockman–Sharpe class whose peak is not 560/530/419 nm; a non-positive peak.
pub fn sensitivities(
    classes: &[ConeClass],
    template: &ConeTemplate,
    grid: &WavelengthGrid,
) -> Result<ConeFundamentals> {
    let (lo, hi) = (grid.min_nm(), grid.max_nm());
    let n_dense = ((hi - lo) / PEAK_SEARCH_STEP_NM).floor() as usize + 1;
    let dense: Vec<f64> = (0..n_dense)
        .map(|i| lo + i as f64 * PEAK_SEARCH_STEP_NM)
        .chain(grid.as_slice().iter().copied())
        .collect();
    let lens_table = data::ocular_media_density();
    let lens_col = lens_table.column_index("ocular_media_od_32yr")?;
    let uses_lens = matches!(
        template,
        ConeTemplate::CarrollNeitz { lens: true, .. }
            | ConeTemplate::Govardovskii { lens: true, .. }
    );
    if uses_lens {
        lens_table.check_covers(lo, hi)?;
    }
    let k = classes.len();
    let mut values = vec![0.0; grid.len() * k];
    for (c, class) in classes.iter().enumerate() {
        if !(class.peak_nm > 0.0 && class.peak_nm.is_finite()) {
            return Err(ColorimetryError::setting(
                format!("cone class {} peak_nm", class.name),
                format!("{} is not a positive wavelength", class.peak_nm),
            ));
        }
        let curve: Box<dyn Fn(f64) -> f64> = match template {
            ConeTemplate::CarrollNeitz {
                optical_density,
                lens,
            } => {
                let (od, lens) = (*optical_density, *lens);
                let peak = class.peak_nm;
                Box::new(move |w| {
                    let t = if lens {
                        10f64.powf(-lens_table.interpolate_index(lens_col, w).unwrap_or(0.0))
                    } else {
                        1.0
                    };
                    neitz_sensitivity(peak, w, od) * t
                })
            }
            ConeTemplate::Govardovskii {
                beta_band,
                optical_density,
                lens,
            } => {
                let (od, lens, beta) = (*optical_density, *lens, *beta_band);
                let peak = class.peak_nm;
                Box::new(move |w| {
                    let mut a = govardovskii_alpha(peak, w);
                    if beta {
                        a += govardovskii_beta(peak, w);
                    }
                    let t = if lens {
                        10f64.powf(-lens_table.interpolate_index(lens_col, w).unwrap_or(0.0))
                    } else {
                        1.0
                    };
                    self_screen(a, od) * t
                })
            }
            ConeTemplate::StockmanSharpe2deg => {
                let table = data::stockman_sharpe_2deg();
                table.check_covers(lo, hi)?;
                let col = stockman_sharpe_column(class)?;
                let ci = table.column_index(col)?;
                Box::new(move |w| interp_linear(&table.wavelengths_nm, &table.values[ci], w))
            }
        };
        let peak = dense.iter().map(|&w| curve(w)).fold(f64::MIN, f64::max);
        if !(peak > 0.0) {
            return Err(ColorimetryError::setting(
                format!("cone class {}", class.name),
                format!("sensitivity is zero everywhere on {lo}–{hi} nm"),
            ));
        }
        for (wi, &w) in grid.as_slice().iter().enumerate() {
            values[wi * k + c] = curve(w) / peak;
        }
    }
    Ok(ConeFundamentals {
        grid: grid.clone(),
        classes: classes.to_vec(),
        values,
    })
}

fn stockman_sharpe_column(class: &ConeClass) -> Result<&'static str> {
    let p = class.peak_nm;
    if p == L_PEAK_NM {
        Ok("l_bar")
    } else if p == M_PEAK_NM {
        Ok("m_bar")
    } else if p == S_PEAK_NM {
        Ok("s_bar")
    } else {
        Err(ColorimetryError::setting(
            format!("cone class {} peak_nm", class.name),
            format!(
                "{p} nm: the tabulated Stockman–Sharpe template has only L ({L_PEAK_NM}), \
                 M ({M_PEAK_NM}) and S ({S_PEAK_NM}); use an analytic template for other peaks"
            ),
        ))
    }
}
