//! Writing CMF-SIM results: `cmf_sim.json` and SVG plots of the error curves.

use std::path::{Path, PathBuf};

use crate::cmf_sim::CmfSimResult;
use crate::error::{ColorimetryError, Result};
use crate::plot::{LinePlot, Series};

/// File name of the JSON result (top-level integer field `dimension`).
pub const CMF_SIM_JSON: &str = "cmf_sim.json";
/// File name of the error-curve plot.
pub const CMF_SIM_SVG: &str = "cmf_sim_errors.svg";

impl CmfSimResult {
    /// The paper's Fig. 4/8: matching error per test wavelength for 0..K primaries (best set at
    /// each K), with the base error and the pass threshold dashed; log y axis, clipped at
    /// 1e-8 of the largest energy so that exact matches sit on the bottom edge.
    pub fn error_plot(&self) -> LinePlot {
        let title = format!("CMF-SIM — {} — {}", self.observer, self.verdict);
        let mut p = LinePlot::new(title, "test wavelength (nm)", "matching error ‖Δpercept‖²");
        p.y.log = true;
        let top = self.energy.iter().copied().fold(0.0, f64::max);
        if top > 0.0 {
            p.y_min = Some(1e-8 * top);
        }
        let x = self.test_wavelengths_nm.clone();
        for c in &self.curves {
            let label = if c.n_primaries == 0 {
                format!("0 primaries (energy), area {:.3e}", c.area)
            } else {
                format!("{} primaries, area {:.3e}", c.n_primaries, c.area)
            };
            p.push(Series::new(label, x.clone(), c.errors.clone()));
        }
        p.push(
            Series::new("base error", x.clone(), self.base_error.clone())
                .dashed()
                .color("#777777"),
        );
        p.push(
            Series::new(
                format!("pass threshold ({}× base)", self.settings.pass_ratio),
                x,
                self.threshold.clone(),
            )
            .dashed()
            .color("#bbbbbb"),
        );
        p.width_px = 860.0;
        p
    }

    /// Serialise to pretty JSON.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("CmfSimResult serialises")
    }

    /// Write `cmf_sim.json` and `cmf_sim_errors.svg` into `dir` (created if missing), each
    /// atomically ([`atomic_io::write_atomic`]): a file is either the old one or the new one,
    /// never half-written. Returns the paths written.
    pub fn save(&self, dir: impl AsRef<Path>) -> Result<Vec<PathBuf>> {
        let dir = dir.as_ref();
        let json = dir.join(CMF_SIM_JSON);
        atomic_io::write_atomic(&json, self.to_json().as_bytes())?;
        let svg = dir.join(CMF_SIM_SVG);
        self.error_plot().save(&svg)?;
        Ok(vec![json, svg])
    }

    /// Read a `cmf_sim.json` back.
    pub fn load(path: impl AsRef<Path>) -> Result<CmfSimResult> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|source| ColorimetryError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        serde_json::from_str(&text).map_err(|source| ColorimetryError::Json {
            path: path.to_path_buf(),
            source,
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::analytic::ConeObserver;
    use crate::cmf_sim::{run_cmf_sim, CmfSimResult, CmfSimSettings};
    use crate::cones::{ConeClass, ConeTemplate};
    use crate::grid::WavelengthGrid;

    #[test]
    fn json_has_integer_dimension_and_round_trips() {
        let o = ConeObserver::new(
            &[ConeClass::l(), ConeClass::s()],
            &ConeTemplate::default(),
            &WavelengthGrid::default(),
        )
        .unwrap();
        let s = CmfSimSettings {
            sets_per_k: 5,
            location_pairs: 1,
            ..CmfSimSettings::default()
        };
        let r = run_cmf_sim(&o, &s).unwrap();
        let dir = std::env::temp_dir().join(format!("colorimetry-cmf-sim-{}", std::process::id()));
        let paths = r.save(&dir).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&paths[0]).unwrap()).unwrap();
        assert_eq!(v["dimension"].as_u64(), Some(2));
        let svg = std::fs::read_to_string(&paths[1]).unwrap();
        assert_eq!(svg.matches("<path").count(), r.curves.len() + 2);
        // serde_json parses floats to within an ulp or so, not always bit-exactly
        let back = CmfSimResult::load(&paths[0]).unwrap();
        assert_eq!(
            (back.dimension, &back.verdict, back.curves.len()),
            (r.dimension, &r.verdict, r.curves.len())
        );
        for (a, b) in back
            .base_error
            .iter()
            .zip(&r.base_error)
            .chain(back.curves[1].errors.iter().zip(&r.curves[1].errors))
        {
            assert!((a - b).abs() <= 1e-14 * b.abs(), "{a} vs {b}");
        }
        let e = CmfSimResult::load(dir.join("missing.json"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.json"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
