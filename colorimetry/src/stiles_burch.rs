//! The colour-matching experiment with the Stiles & Burch (1955) primaries, compared with their
//! 2° CMFs (paper RS-08, Fig. 11; docs/references.md#stiles-burch).
//!
//! For every Stiles–Burch wavelength inside the observer's grid (5 nm steps), an equal-energy
//! test light of intensity I is matched with the fixed primaries 645.2 / 526.3 / 444.4 nm by the
//! CMF-SIM solver ([`crate::matching`]); α(λ), with its negative lobes, is the simulated CMF
//! (r̄, ḡ, b̄ in that order). α is in units of I, so α_c = 1 at the c-th primary, which is also
//! the normalisation of the tabulated Stiles–Burch curves (≈ 1 at their own primary).
//!
//! Scaling for the comparison: each simulated channel is multiplied by the least-squares gain
//! `g_c = Σ α_c·sb_c / Σ α_c²` (the single factor that best fits the tabulated curve), then the
//! RMSE and the Pearson correlation with the tabulated curve are reported. The gain is reported
//! too; for an observer with energy-based sensitivities it should be ≈ 1.

use std::path::{Path, PathBuf};

use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

use crate::data;
use crate::error::{ColorimetryError, Result};
use crate::matching::{solve_matches, MatchProblem, SolverSettings};
use crate::observer::Observer;
use crate::plot::{LinePlot, Series};

/// Stiles & Burch 1955 2° primaries, nm, in r̄, ḡ, b̄ order.
pub const STILES_BURCH_PRIMARIES_NM: [f64; 3] = [645.2, 526.3, 444.4];

/// Settings of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct StilesBurchSettings {
    /// Location pairs per evaluation.
    pub location_pairs: usize,
    /// Test intensity; `None` = [`Observer::stimulus_intensity`].
    pub intensity: Option<f64>,
    /// α solver.
    pub solver: SolverSettings,
    /// RNG seed.
    pub seed: u64,
}

impl Default for StilesBurchSettings {
    fn default() -> Self {
        StilesBurchSettings {
            location_pairs: 8,
            intensity: None,
            solver: SolverSettings::default(),
            seed: 0,
        }
    }
}

/// Per-channel agreement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelComparison {
    /// `r_bar`, `g_bar` or `b_bar`.
    pub channel: String,
    /// Primary, nm.
    pub primary_nm: f64,
    /// Least-squares gain applied to the simulated curve.
    pub gain: f64,
    /// RMSE after the gain.
    pub rmse: f64,
    /// RMSE with gain 1 (the natural α scale).
    pub rmse_unscaled: f64,
    /// Pearson correlation (gain-independent).
    pub correlation: f64,
}

/// Result of the comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StilesBurchResult {
    /// Observer description.
    pub observer: String,
    /// Test wavelengths, nm.
    pub wavelengths_nm: Vec<f64>,
    /// Simulated α per channel (r̄, ḡ, b̄), unscaled.
    pub simulated: [Vec<f64>; 3],
    /// Tabulated Stiles–Burch values per channel.
    pub reference: [Vec<f64>; 3],
    /// Matching error per wavelength.
    pub match_errors: Vec<f64>,
    /// Per-channel comparison.
    pub channels: Vec<ChannelComparison>,
}

/// Pearson correlation of two equal-length series.
pub fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma).powi(2);
        sbb += (y - mb).powi(2);
    }
    sab / (saa * sbb).sqrt()
}

fn rmse(a: &[f64], b: &[f64], gain: f64) -> f64 {
    (a.iter()
        .zip(b)
        .map(|(x, y)| (gain * x - y).powi(2))
        .sum::<f64>()
        / a.len() as f64)
        .sqrt()
}

/// Run the fixed-primary matching experiment on `observer` and compare with Stiles & Burch.
pub fn compare_stiles_burch(
    observer: &dyn Observer,
    settings: &StilesBurchSettings,
) -> Result<StilesBurchResult> {
    if settings.location_pairs == 0 {
        return Err(ColorimetryError::setting("location_pairs", "must be ≥ 1"));
    }
    let sb = data::stiles_burch_1955();
    let g = observer.grid();
    let idx: Vec<usize> = (0..sb.n_wavelengths())
        .filter(|&i| {
            sb.wavelengths_nm[i] >= g.min_nm() - 1e-9 && sb.wavelengths_nm[i] <= g.max_nm() + 1e-9
        })
        .collect();
    if idx.len() < 3 {
        return Err(ColorimetryError::setting(
            "observer grid",
            format!(
                "{}–{} nm holds fewer than 3 Stiles–Burch wavelengths",
                g.min_nm(),
                g.max_nm()
            ),
        ));
    }
    let wavelengths: Vec<f64> = idx.iter().map(|&i| sb.wavelengths_nm[i]).collect();
    let mut rng = rand::rngs::StdRng::seed_from_u64(settings.seed);
    let pairs: Vec<Vec<[[f64; 2]; 2]>> = wavelengths
        .iter()
        .map(|_| {
            (0..settings.location_pairs)
                .map(|_| observer.location_pair(&mut rng))
                .collect()
        })
        .collect();
    let pb = MatchProblem {
        observer,
        test_wavelengths_nm: &wavelengths,
        primaries_nm: &STILES_BURCH_PRIMARIES_NM,
        intensity: settings
            .intensity
            .unwrap_or_else(|| observer.stimulus_intensity()),
        pairs: &pairs,
        seed: rng.random(),
    };
    let sol = solve_matches(&pb, &settings.solver);
    let simulated: [Vec<f64>; 3] =
        std::array::from_fn(|c| sol.alphas.iter().map(|a| a[c]).collect());
    let reference: [Vec<f64>; 3] =
        std::array::from_fn(|c| idx.iter().map(|&i| sb.values[c][i]).collect());
    let channels = (0..3)
        .map(|c| {
            let (a, b) = (&simulated[c], &reference[c]);
            let gain = a.iter().zip(b).map(|(x, y)| x * y).sum::<f64>()
                / a.iter().map(|x| x * x).sum::<f64>();
            ChannelComparison {
                channel: sb.columns[c].clone(),
                primary_nm: STILES_BURCH_PRIMARIES_NM[c],
                gain,
                rmse: rmse(a, b, gain),
                rmse_unscaled: rmse(a, b, 1.0),
                correlation: correlation(a, b),
            }
        })
        .collect();
    Ok(StilesBurchResult {
        observer: observer.name(),
        wavelengths_nm: wavelengths,
        simulated,
        reference,
        match_errors: sol.errors,
        channels,
    })
}

impl StilesBurchResult {
    /// Simulated (scaled, solid) and tabulated (dashed) CMFs.
    pub fn plot(&self) -> LinePlot {
        let mut p = LinePlot::new(
            format!(
                "CMFs with primaries 645.2 / 526.3 / 444.4 nm — {}",
                self.observer
            ),
            "wavelength (nm)",
            "tristimulus value",
        );
        let colors = ["#D55E00", "#009E73", "#0072B2"];
        for (c, ch) in self.channels.iter().enumerate() {
            let scaled: Vec<f64> = self.simulated[c].iter().map(|v| v * ch.gain).collect();
            let label = format!(
                "{} sim ×{:.3} (r = {:.4}, RMSE {:.4})",
                ch.channel, ch.gain, ch.correlation, ch.rmse
            );
            p.push(Series::new(label, self.wavelengths_nm.clone(), scaled).color(colors[c]));
            p.push(
                Series::new(
                    format!("{} Stiles & Burch 1955", ch.channel),
                    self.wavelengths_nm.clone(),
                    self.reference[c].clone(),
                )
                .color(colors[c])
                .dashed(),
            );
        }
        p.width_px = 900.0;
        p
    }

    /// Write `stiles_burch.json` and `stiles_burch.svg` into `dir` (created if missing), each
    /// atomically ([`atomic_io::write_atomic`]).
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<Vec<PathBuf>> {
        let dir = dir.as_ref();
        let json = dir.join("stiles_burch.json");
        let text = serde_json::to_string_pretty(self).expect("serialises");
        atomic_io::write_atomic(&json, text.as_bytes())?;
        let svg = dir.join("stiles_burch.svg");
        self.plot().save(&svg)?;
        Ok(vec![json, svg])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analytic::ConeObserver;
    use crate::cones::{ConeClass, ConeTemplate};
    use crate::grid::WavelengthGrid;

    #[test]
    fn stockman_sharpe_observer_matches_stiles_burch() {
        // correlation ≥ 0.98 per channel.
        let g = WavelengthGrid::range(390.0, 730.0, 1.0).unwrap();
        let o =
            ConeObserver::new(&ConeClass::lms(), &ConeTemplate::StockmanSharpe2deg, &g).unwrap();
        let s = StilesBurchSettings {
            location_pairs: 1,
            ..StilesBurchSettings::default()
        };
        let r = compare_stiles_burch(&o, &s).unwrap();
        assert_eq!(r.wavelengths_nm.len(), 69);
        for ch in &r.channels {
            eprintln!(
                "{}: r = {:.5}, RMSE {:.5} (gain {:.4}), RMSE unscaled {:.5}",
                ch.channel, ch.correlation, ch.rmse, ch.gain, ch.rmse_unscaled
            );
            assert!(ch.correlation >= 0.98, "{ch:?}");
        }
        // the simulated curves cross zero at the other primaries, as the real ones (docs/references.md#colorimetry-formulas):
        // r̄ is negative between the blue and green primaries
        let i505 = r.wavelengths_nm.iter().position(|&w| w == 505.0).unwrap();
        assert!(r.simulated[0][i505] < 0.0);
        let svg = r.plot().to_svg();
        assert_eq!(svg.matches("<path").count(), 6);
    }

    #[test]
    fn correlation_of_scaled_copy_is_one() {
        let a = [1.0, 2.0, 0.5, -1.0];
        let b: Vec<f64> = a.iter().map(|v| 3.0 * v).collect();
        assert!((correlation(&a, &b) - 1.0).abs() < 1e-12);
        assert!((rmse(&a, &b, 3.0)).abs() < 1e-12);
    }
}
