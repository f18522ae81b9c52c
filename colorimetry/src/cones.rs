//! Cone spectral sensitivities: pigment templates, lens filtering, peak normalisation.
//!
//! Templates (docs/references.md#govardovskii-template, #cone-template-formulas and, for the
//! authors' choice, #cone-templates):
//! - [`ConeTemplate::CarrollNeitz`]: the Carroll, McMahon, Neitz & Neitz (2000) template (the
//!   Neitz-lab `spectsens`) with self-screening at peak optical density OD:
//!   `(1 − 10^(−Z·ext)) / (1 − 10^(−Z))`, `Z = OD + 1e-8`. The official code uses OD = 0.001
//!   ([`OFFICIAL_OPTICAL_DENSITY`]), the lab's own default is 0.2.
//! - [`ConeTemplate::Govardovskii`]: Govardovskii et al. (2000) A1 template, α band or α + β,
//!   with the same self-screening.
//! - [`ConeTemplate::StockmanSharpe2deg`]: the tabulated Stockman & Sharpe (2000) 2° fundamentals
//!   (energy, lens and macular pigment already included); classes must be L/M/S (560/530/419).
//!
//! With `lens: true` an analytic template is multiplied by the lens transmittance
//! `10^(−d_lens(λ))` (Stockman–Sharpe ocular media density, 32-year observer; no macular
//! pigment — authors' code, docs/references.md#cone-templates). Every curve is then normalised to peak 1 over the grid's range; the
//! peak is found on a 0.1 nm sampling of that range, so the normalisation does not depend on the
//! grid's spacing (the official code normalises on 400–700 nm at 1 nm).
//!
//! Units: sensitivities are relative (peak 1), per unit of whatever spectral quantity the scene
//! holds — the official code applies the quantal templates directly to NTIRE radiance, with no
//! λ factor, and so do we. Output layout: [`ConeFundamentals::values`] is row-major
//! `(wavelengths × classes)`.

use serde::{Deserialize, Serialize};

use crate::data;
use crate::error::{ColorimetryError, Result};
use crate::grid::WavelengthGrid;
use crate::table::interp_linear;

mod fundamentals;

pub use fundamentals::{sensitivities, ConeFundamentals};

/// λmax of the L pigment, nm (authors' code, docs/references.md#cone-templates, paper S-02).
pub const L_PEAK_NM: f64 = 560.0;
/// λmax of the M pigment, nm (authors' code, docs/references.md#cone-templates, paper S-02).
pub const M_PEAK_NM: f64 = 530.0;
/// λmax of the S pigment, nm (authors' code, docs/references.md#cone-templates, paper S-02).
pub const S_PEAK_NM: f64 = 419.0;
/// λmax of the human tetrachromat's fourth pigment Q, nm (paper S-07).
pub const HUMAN_Q_PEAK_NM: f64 = 545.0;
/// λmax of the pigeon-like fourth pigment Q, nm (paper S-07).
pub const PIGEON_Q_PEAK_NM: f64 = 506.0;
/// Peak optical density used by the official code's Carroll/Neitz template (authors' code, docs/references.md#cone-templates).
pub const OFFICIAL_OPTICAL_DENSITY: f64 = 0.001;
/// Spacing (nm) of the dense sampling used to find each curve's peak for normalisation.
pub const PEAK_SEARCH_STEP_NM: f64 = 0.1;

/// A cone class: a name and the pigment's λmax (the template's shift parameter, nm).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ConeClass {
    /// Display name, e.g. `L`.
    pub name: String,
    /// Pigment λmax, nm (before the lens; the effective peak after the lens is longer).
    pub peak_nm: f64,
}

impl ConeClass {
    /// A class with any name and peak.
    pub fn custom(name: impl Into<String>, peak_nm: f64) -> Self {
        ConeClass {
            name: name.into(),
            peak_nm,
        }
    }
    /// L cone, λmax 560 nm.
    pub fn l() -> Self {
        Self::custom("L", L_PEAK_NM)
    }
    /// M cone, λmax 530 nm.
    pub fn m() -> Self {
        Self::custom("M", M_PEAK_NM)
    }
    /// S cone, λmax 419 nm.
    pub fn s() -> Self {
        Self::custom("S", S_PEAK_NM)
    }
    /// Human tetrachromat Q, λmax 545 nm.
    pub fn human_q() -> Self {
        Self::custom("Q", HUMAN_Q_PEAK_NM)
    }
    /// Pigeon-like Q, λmax 506 nm.
    pub fn pigeon_q() -> Self {
        Self::custom("Q", PIGEON_Q_PEAK_NM)
    }
    /// `[L, M, S]`.
    pub fn lms() -> Vec<Self> {
        vec![Self::l(), Self::m(), Self::s()]
    }
}

/// Which pigment template, and its options.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum ConeTemplate {
    /// Carroll/Neitz `spectsens` with peak optical density and optional lens.
    CarrollNeitz {
        /// Peak optical density (official 0.001; the Neitz lab default 0.2).
        optical_density: f64,
        /// Multiply by the lens transmittance.
        lens: bool,
    },
    /// Govardovskii 2000 A1 template.
    Govardovskii {
        /// Include the β (cis) band.
        beta_band: bool,
        /// Peak optical density for self-screening (use ≈0 for the bare template).
        optical_density: f64,
        /// Multiply by the lens transmittance.
        lens: bool,
    },
    /// Tabulated Stockman & Sharpe 2000 2° energy fundamentals (L/M/S only).
    StockmanSharpe2deg,
}

impl Default for ConeTemplate {
    /// The official choice: Carroll/Neitz, OD 0.001, with lens (authors' code, docs/references.md#cone-templates).
    fn default() -> Self {
        ConeTemplate::CarrollNeitz {
            optical_density: OFFICIAL_OPTICAL_DENSITY,
            lens: true,
        }
    }
}

const NEITZ: [f64; 25] = [
    0.417050601,  // A
    0.002072146,  // B
    0.000163888,  // C
    -1.922880605, // D
    -16.05774461, // E
    0.001575426,  // F
    5.11376e-05,  // G
    0.00157981,   // H
    6.58428e-05,  // I
    6.68402e-05,  // J
    0.002310442,  // K
    7.31313e-05,  // L
    1.86269e-05,  // M
    0.002008124,  // N
    5.40717e-05,  // O
    5.14736e-06,  // P
    0.001455413,  // Q
    4.21764e-05,  // R
    4.8e-06,      // S
    0.001809022,  // T
    3.86677e-05,  // U
    2.99e-05,     // V
    0.001757315,  // W
    1.47344e-05,  // X
    1.51e-05,     // Y
];

fn phi(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// log10 of the Carroll/Neitz low-density extinction (≈ 0 at the peak), docs/references.md#cone-template-formulas.
pub fn neitz_log10_extinction(peak_nm: f64, wavelength_nm: f64) -> f64 {
    let [a, b, c, d, e, f, g, h, i, j, k, l, m, n, o, p, q, r, s, t, u, v, w, x, y] = NEITZ;
    let z = peak_nm / 558.5 / wavelength_nm;
    (-e + e * (-(z - f) / g).tanh()).log10() + d + a * (-(z - b) / c).tanh()
        - (j / i) * phi((z - h) / i)
        - (m / l) * phi((z - k) / l)
        - (p / o) * phi((z - n) / o)
        + (s / r) * phi((z - q) / r)
        + (v / u) * phi((z - t) / u) / 10.0
        + (y / x) * phi((z - w) / x) / 100.0
}

/// Self-screening: absorptance of a pigment of peak density OD with low-density absorbance
/// `ext`, normalised to 1 where `ext = 1`. Uses `Z = OD + 1e-8` (as the Neitz-lab code).
pub fn self_screen(ext: f64, optical_density: f64) -> f64 {
    let zd = optical_density + 1e-8;
    (1.0 - 10f64.powf(-zd * ext)) / (1.0 - 10f64.powf(-zd))
}

/// Carroll/Neitz sensitivity with self-screening (no lens, no renormalisation).
pub fn neitz_sensitivity(peak_nm: f64, wavelength_nm: f64, optical_density: f64) -> f64 {
    self_screen(
        10f64.powf(neitz_log10_extinction(peak_nm, wavelength_nm)),
        optical_density,
    )
}

/// Govardovskii 2000 A1 α band, docs/references.md#govardovskii-template (peak ≈ 1.0008, not renormalised).
pub fn govardovskii_alpha(peak_nm: f64, wavelength_nm: f64) -> f64 {
    let x = peak_nm / wavelength_nm;
    let a = 0.8795 + 0.0459 * (-(peak_nm - 300.0).powi(2) / 11940.0).exp();
    1.0 / ((69.7 * (a - x)).exp()
        + (28.0 * (0.922 - x)).exp()
        + (-14.9 * (1.104 - x)).exp()
        + 0.674)
}

/// Govardovskii 2000 β band alone.
pub fn govardovskii_beta(peak_nm: f64, wavelength_nm: f64) -> f64 {
    let lm = 189.0 + 0.315 * peak_nm;
    let bw = -40.5 + 0.195 * peak_nm;
    0.26 * (-((wavelength_nm - lm) / bw).powi(2)).exp()
}

/// Lens (ocular media) transmittance `10^(−d_lens(λ))`, Stockman–Sharpe 32-year density,
/// linearly interpolated from the 1 nm table (390–830 nm). Error outside that range.
pub fn lens_transmittance(wavelength_nm: f64) -> Result<f64> {
    let d = data::ocular_media_density().interpolate("ocular_media_od_32yr", wavelength_nm)?;
    Ok(10f64.powf(-d))
}

#[cfg(test)]
mod tests;
