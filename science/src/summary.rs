//! A run's record, `summary.json` ([`Summary`]): its final CMF-SIM dimension and margins, the
//! dimension over training, held-out prediction, the learned invariants and the resolved config;
//! and how its figures are written in words and tables ([`margins_text`], [`digits_grouped`]).
//!
//! Conventions: a dimension of 0 is "undefined" (no colour constancy) when measured; a margin is
//! the converged worst error over every test wavelength of a K's reported primary set, in units
//! of the threshold (below 1 passes).

use crate::config::RunConfig;
use crate::invariants::Recovery;
use colorimetry::CmfSimResult;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// Learned invariants against the truth and what the Neural Scope reads from the percept.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Invariants {
    /// C, W and P against the eye's truth ([`crate::invariants`]).
    pub recovery: Recovery,
    /// RMSE of the Neural Scope on held-out scenes (linear sRGB).
    pub scope_rmse: f64,
    /// Hue axis (CIELAB a*b*) of the Neural-Scope colours of the held-out pixels (paper Fig. 5.2:
    /// one axis for a dichromat).
    pub scope_hue_axis: Option<colorimetry::HueAxis>,
    /// The same for the true colours of those pixels (the scenes' own spread, for comparison).
    pub truth_hue_axis: Option<colorimetry::HueAxis>,
    /// The known answer for this retina: the hue axis of a Neural Scope fitted on the true
    /// excitation of every cone class at each pixel — an ideal observer with exactly this eye's
    /// cone classes (a dichromat's one axis: blue–yellow without L or M, teal–pink without S).
    #[serde(default)]
    pub ideal_hue_axis: Option<colorimetry::HueAxis>,
    /// How far the Neural-Scope hues lie from the true ones over the held-out pixels of
    /// chroma C*ab ≥ [`HUE_ERROR_MIN_CHROMA`] ([`colorimetry::hue_error`]).
    #[serde(default)]
    pub scope_hue_error: Option<colorimetry::HueError>,
    /// The last cone class's own signal (what the other classes do not predict) as the percept
    /// reads it on held-out scenes: the picture `pictures/own_<class>.png` and its held-out R²
    /// ([`crate::invariants::own_image`]); `None` for a one-class eye.
    #[serde(default)]
    pub own_image: Option<OwnImageFigure>,
}

/// The figure of [`Invariants::own_image`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct OwnImageFigure {
    /// The class whose own signal is shown (the eye's last class: S for LMS, Q for LMSQ).
    pub class: String,
    /// Held-out R² of the percept's reading of it, over every site of the scoring scenes.
    #[serde(deserialize_with = "nan_for_null")]
    pub held_out_r2: f64,
}

impl OwnImageFigure {
    /// The picture's file name in `pictures/`: `own_<class>.png`, the class name's characters
    /// other than letters and digits written as `_`.
    pub fn file_name(&self) -> String {
        let class: String = (self.class.chars())
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        format!("own_{class}.png")
    }
}

/// A figure written as `null` (JSON has no NaN) read back as NaN.
fn nan_for_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::NAN))
}

/// The chroma (CIELAB C*ab) from which a pixel's hue counts in the hue error: greys have no
/// hue to get right.
pub const HUE_ERROR_MIN_CHROMA: f64 = 10.0;

/// One CMF-SIM measurement during training.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct DimensionPoint {
    /// Steps done.
    pub step: u64,
    /// Dimension measured (0: undefined).
    pub dimension: usize,
    /// Seconds CMF-SIM took.
    pub seconds: f64,
    /// Seconds since the run started, when this measurement finished.
    pub wall_seconds: f64,
    /// Primary sets per K of this measurement's budget.
    pub sets_per_k: usize,
    /// Test wavelengths of this measurement's budget.
    pub test_wavelengths: usize,
}

/// `summary.json`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Summary {
    /// The colour dimensionality CMF-SIM measured at the end (0 when not measured or undefined).
    pub dimension: usize,
    /// Gradient updates done.
    pub steps: u64,
    /// Steps of the checkpoints the run was resumed from, in order (empty: never stopped).
    #[serde(default)]
    pub resumed_at_steps: Vec<u64>,
    /// Wall time of the whole run (its parts, when resumed), s.
    pub wall_seconds: f64,
    /// Mean training-step time, ms.
    pub mean_step_ms: f64,
    /// Whether the cortex received the oracle eye motion.
    pub oracle_motion: bool,
    /// Dimension over training.
    pub dimension_over_steps: Vec<DimensionPoint>,
    /// First measurement of each dimension 1, 2, 3, …: `(dimension, step, seconds since the
    /// run started)`.
    pub first_step_at_dimension: Vec<(usize, u64, f64)>,
    /// Held-out prediction error at the end: `[model MSE, "next = current" MSE, ratio]`.
    pub heldout_prediction: Option<[f64; 3]>,
    /// Mean distance of the estimated eye motion from the true one on held-out batches at the
    /// end, ONS pixels (`None` with oracle motion).
    pub heldout_motion_error_px: Option<f64>,
    /// CMF-SIM verdict at the end.
    pub verdict: String,
    /// Per K tried at the end, in words: the converged margin of its reported set (see
    /// [`colorimetry::cmf_sim::KSummary::describe`]).
    pub cmf_sim_per_k: Vec<String>,
    /// Per K tried at the end: `(K, converged max error / threshold over every wavelength)`;
    /// < 1 passes.
    pub converged_ratio_per_k: Vec<(usize, f64)>,
    /// Learned invariants against the truth (evaluation only).
    pub invariants: Option<Invariants>,
    /// The resolved config.
    pub config: RunConfig,
}

/// The last CMF-SIM measurement, as the summary reports it.
#[derive(Clone, Debug, Default, Serialize, Deserialize)]
pub struct LastMeasurement {
    /// Step measured at.
    pub step: u64,
    /// Dimension (0: undefined).
    pub dimension: usize,
    /// Verdict.
    pub verdict: String,
    /// Per K tried, the converged margin in words ([`colorimetry::cmf_sim::KSummary::describe`]).
    pub cmf_sim_per_k: Vec<String>,
    /// `(K, converged max error / threshold over every wavelength)` per K tried.
    pub converged_ratio_per_k: Vec<(usize, f64)>,
}

impl LastMeasurement {
    /// What the CMF-SIM result `r`, measured at `step`, reports.
    pub fn of(step: u64, r: &CmfSimResult) -> Self {
        LastMeasurement {
            step,
            dimension: r.dimension,
            verdict: r.verdict.clone(),
            cmf_sim_per_k: (r.per_k.iter())
                .map(|q| q.describe(r.test_wavelengths_nm.len()))
                .collect(),
            converged_ratio_per_k: (r.per_k.iter())
                .map(|q| (q.n_primaries, q.converged_worst_ratio))
                .collect(),
        }
    }
}

impl Summary {
    /// Reads `summary.json` at `path`; the error in words.
    pub fn read(path: &Path) -> Result<Summary, String> {
        read_json(path)
    }

    /// The summary of an observer measured without training (S-05's Φ = identity baselines):
    /// no step done, one CMF-SIM measurement `r` with `config.cmf_sim`, no learned invariants.
    pub fn untrained(config: &RunConfig, r: &CmfSimResult) -> Summary {
        let measured = LastMeasurement::of(0, r);
        Summary {
            dimension: r.dimension,
            steps: 0,
            resumed_at_steps: Vec::new(),
            wall_seconds: r.seconds,
            mean_step_ms: 0.0,
            oracle_motion: config.oracle_motion,
            dimension_over_steps: vec![DimensionPoint {
                step: 0,
                dimension: r.dimension,
                seconds: r.seconds,
                wall_seconds: r.seconds,
                sets_per_k: config.cmf_sim.sets_per_k,
                test_wavelengths: config.cmf_sim.n_test_wavelengths,
            }],
            first_step_at_dimension: match r.dimension {
                0 => Vec::new(),
                d => vec![(d, 0, r.seconds)],
            },
            heldout_prediction: None,
            heldout_motion_error_px: None,
            verdict: measured.verdict,
            cmf_sim_per_k: measured.cmf_sim_per_k,
            converged_ratio_per_k: measured.converged_ratio_per_k,
            invariants: None,
            config: config.clone(),
        }
    }
}

/// CMF-SIM's margins in short, e.g. "K1 4.54, K2 1.02, K3 0.99": per K tried, the reported
/// set's worst error over every test wavelength in units of the threshold (above 1 fails,
/// below 1 passes).
pub fn margins_text(converged_ratio_per_k: &[(usize, f64)]) -> String {
    converged_ratio_per_k
        .iter()
        .map(|(k, r)| format!("K{k} {r:.2}"))
        .collect::<Vec<_>>()
        .join(", ")
}

/// `n` with its digits in groups of three joined by `separator`: `80 000`.
pub fn digits_grouped(n: u64, separator: char) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(separator);
        }
        out.push(c);
    }
    out
}

/// Reads the JSON file `path` as a `T`; the error says why it does not read (the file, or
/// the field), for the caller to put beside the path.
pub fn read_json<T: serde::de::DeserializeOwned>(path: &Path) -> Result<T, String> {
    let text = std::fs::read_to_string(path).map_err(|e| e.to_string())?;
    serde_json::from_str(&text).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_written_as_the_docs_write_them() {
        assert_eq!(digits_grouped(999, ' '), "999");
        assert_eq!(digits_grouped(40_000, ' '), "40 000");
        assert_eq!(digits_grouped(1_234_567, ','), "1,234,567");
        assert_eq!(margins_text(&[(1, 4.537), (2, 0.994)]), "K1 4.54, K2 0.99");
        assert_eq!(margins_text(&[]), "");
    }
}
