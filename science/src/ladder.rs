//! The calibration ladder of CMF-SIM: observers that share the real eye — the same disc
//! stimuli, foveated mosaic, lateral inhibition and noise as a learned cortex sees — but whose
//! colour dimension is known, each measured with exactly the protocol that then judges learned
//! cortices (`colorvision experiment cmf-ladder`).
//!
//! | rung | observer | known answer |
//! |---|---|---|
//! | identity | Φ = identity on the ONS (paper S-05 baseline 1) | no colour constancy |
//! | cones | the cone activations, no lateral inhibition (S-05 baseline 2) | 1 |
//! | oracle L, M, S | LI inverted, each kind interpolated, embedded in N = 8 | 1 |
//! | oracle LM, LS, MS | the same | 2 |
//! | oracle LMS | the same | 3 |
//! | oracle LMS + pigeon Q (506 nm), + human Q (545 nm) | the same | 4 |
//! | oracle LMS + ½L½M | a fourth kind inside the span of L and M | 3 |
//! | oracle MS + L:M at random | half the M cones r·L + (1−r)·M, r ~ U(0, 1): L and M solved by least squares over the mixtures | 3 |
//! | oracle-mosaic LMS | each cell keeps its own kind (no demosaicking, S-05 baseline 3) | reported (the paper's cortex without D: 1) |
//!
//! Each rung runs over several seeds of CMF-SIM's location draws; the table gives the verdicts
//! and the converged margins (the passing set's worst ratio at the expected K, the best failing
//! set's at K − 1), for the readout under test and for the patch-mean readout it replaced.

use crate::config::RunConfig;
use crate::measure::measure_observer;
use crate::observer::{ObserverKind, ReadoutMode};
use crate::Error;
use colorimetry::CmfSimResult;
use serde::Serialize;

/// What a rung must return.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Expected {
    /// Base errors exceed the percept energy: no colour constancy, dimension undefined.
    NoConstancy,
    /// This dimension.
    Dimension(usize),
    /// No known answer: reported only.
    Reported,
}

/// One rung: an observer through an eye of the given cones.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Rung {
    /// Short name.
    pub name: &'static str,
    /// The mosaic (`--cones`).
    pub cones: &'static str,
    /// The observer.
    #[serde(skip)]
    pub observer: ObserverKind,
    /// The known answer.
    pub expected: Expected,
}

const fn rung(
    name: &'static str,
    cones: &'static str,
    observer: ObserverKind,
    e: Expected,
) -> Rung {
    Rung {
        name,
        cones,
        observer,
        expected: e,
    }
}

/// The ladder (module docs).
pub const LADDER: &[Rung] = &[
    rung(
        "identity",
        "LMS",
        ObserverKind::Identity,
        Expected::NoConstancy,
    ),
    rung("cones", "LMS", ObserverKind::Cones, Expected::Dimension(1)),
    rung(
        "oracle L",
        "L",
        ObserverKind::Oracle,
        Expected::Dimension(1),
    ),
    rung(
        "oracle M",
        "M",
        ObserverKind::Oracle,
        Expected::Dimension(1),
    ),
    rung(
        "oracle S",
        "S",
        ObserverKind::Oracle,
        Expected::Dimension(1),
    ),
    rung(
        "oracle LM",
        "LM",
        ObserverKind::Oracle,
        Expected::Dimension(2),
    ),
    rung(
        "oracle LS",
        "LS",
        ObserverKind::Oracle,
        Expected::Dimension(2),
    ),
    rung(
        "oracle MS",
        "MS",
        ObserverKind::Oracle,
        Expected::Dimension(2),
    ),
    rung(
        "oracle LMS",
        "LMS",
        ObserverKind::Oracle,
        Expected::Dimension(3),
    ),
    rung(
        "oracle LMS+pigeon Q",
        "LMSQ,Q:506",
        ObserverKind::Oracle,
        Expected::Dimension(4),
    ),
    rung(
        "oracle LMS+human Q",
        "LMSQ",
        ObserverKind::Oracle,
        Expected::Dimension(4),
    ),
    rung(
        "oracle LMS+½L½M",
        "LMS+L_coexpress_M",
        ObserverKind::Oracle,
        Expected::Dimension(3),
    ),
    rung(
        "oracle MS+L:M at random",
        "MS+L_ratio_M",
        ObserverKind::Oracle,
        Expected::Dimension(3),
    ),
    rung(
        "oracle-mosaic LMS",
        "LMS",
        ObserverKind::OracleMosaic,
        Expected::Reported,
    ),
];

/// One rung measured at one location seed.
#[derive(Clone, Debug, Serialize)]
pub struct Measurement {
    /// CMF-SIM's seed.
    pub location_seed: u64,
    /// Dimension (0: undefined).
    pub dimension: usize,
    /// No colour constancy.
    pub no_colour_constancy: bool,
    /// Σ base / Σ energy.
    pub base_over_energy: f64,
    /// Per K tried: converged worst ratio (< 1 passes).
    pub converged_ratio_per_k: Vec<f64>,
    /// Wall time, s.
    pub seconds: f64,
}

impl Measurement {
    fn of(seed: u64, r: &CmfSimResult) -> Self {
        Measurement {
            location_seed: seed,
            dimension: r.dimension,
            no_colour_constancy: r.no_colour_constancy,
            base_over_energy: r.base_error.iter().sum::<f64>() / r.energy.iter().sum::<f64>(),
            converged_ratio_per_k: r.per_k.iter().map(|k| k.converged_worst_ratio).collect(),
            seconds: r.seconds,
        }
    }

    /// Whether this measurement returns `expected`.
    pub fn returns(&self, expected: Expected) -> bool {
        match expected {
            Expected::NoConstancy => self.no_colour_constancy,
            Expected::Dimension(d) => !self.no_colour_constancy && self.dimension == d,
            Expected::Reported => true,
        }
    }
}

/// `rung` at each seed, with `config`'s preset, budget and readout.
pub fn measure_rung(
    config: &RunConfig,
    rung: &Rung,
    seeds: &[u64],
) -> Result<Vec<Measurement>, Error> {
    let mut c = config.clone();
    c.cones = rung.cones.into();
    c.retina.cones = rung.cones.into();
    c.validate()?;
    seeds
        .iter()
        .map(|&seed| {
            c.cmf_sim.seed = seed;
            Ok(Measurement::of(
                seed,
                &measure_observer(&c, rung.observer, None)?,
            ))
        })
        .collect()
}

/// The readout as a word.
pub fn readout_name(mode: ReadoutMode) -> &'static str {
    match mode {
        ReadoutMode::Resolved => "resolved",
        ReadoutMode::PatchMean => "patch-mean",
    }
}

/// Location seeds of the ladder experiment.
pub const LADDER_SEEDS: u64 = 5;

/// One row of the ladder table.
#[derive(Clone, Debug, Serialize)]
pub struct Row {
    /// The rung.
    pub rung: Rung,
    /// The readout.
    pub readout: &'static str,
    /// One per seed.
    pub measurements: Vec<Measurement>,
}

impl Row {
    /// Whether every seed returned the known answer.
    pub fn calibrated(&self) -> bool {
        self.measurements
            .iter()
            .all(|m| m.returns(self.rung.expected))
    }

    /// The table line: verdicts per seed, base/energy range, and the converged margins at the
    /// expected K (largest over seeds) and at K − 1 (smallest over seeds).
    pub fn markdown(&self) -> String {
        let verdicts: Vec<String> = self
            .measurements
            .iter()
            .map(|m| match m.no_colour_constancy {
                true => "u".into(),
                false => m.dimension.to_string(),
            })
            .collect();
        let be: Vec<f64> = self
            .measurements
            .iter()
            .map(|m| m.base_over_energy)
            .collect();
        let range = |v: &[f64]| {
            let lo = v.iter().cloned().fold(f64::INFINITY, f64::min);
            let hi = v.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
            format!("{lo:.3}–{hi:.3}")
        };
        let margin = |k: usize, pick: fn(f64, f64) -> f64, start: f64| {
            let v = self
                .measurements
                .iter()
                .filter_map(|m| m.converged_ratio_per_k.get(k.checked_sub(1)?).copied())
                .fold(start, pick);
            if v.is_finite() {
                format!("{v:.2}")
            } else {
                "—".into()
            }
        };
        let (pass, fail) = match self.rung.expected {
            Expected::Dimension(d) => (
                margin(d, f64::max, f64::NEG_INFINITY),
                margin(d - 1, f64::min, f64::INFINITY),
            ),
            _ => ("—".into(), "—".into()),
        };
        let expected = match self.rung.expected {
            Expected::NoConstancy => "u".to_string(),
            Expected::Dimension(d) => d.to_string(),
            Expected::Reported => "(1)".to_string(),
        };
        format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            self.rung.name,
            self.readout,
            expected,
            verdicts.join(" "),
            if self.calibrated() { "yes" } else { "**no**" },
            range(&be),
            pass,
            fail
        )
    }
}

/// Table header of [`Row::markdown`].
pub const TABLE_HEADER: &str = "| rung | readout | known | verdicts (seeds 0–4; u = no constancy) | returns it | Σbase/Σenergy | margin at K (max) | margin at K−1 (min) |\n|---|---|---|---|---|---|---|---|";

/// Every rung with both readouts at [`LADDER_SEEDS`] location seeds (`colorvision experiment
/// cmf-ladder`), in table order; `each` sees every row as soon as it is measured.
pub fn measure_ladder(config: &RunConfig, mut each: impl FnMut(&Row)) -> Result<Vec<Row>, Error> {
    let seeds: Vec<u64> = (0..LADDER_SEEDS).collect();
    let mut rows = Vec::new();
    for mode in [ReadoutMode::Resolved, ReadoutMode::PatchMean] {
        let mut c = config.clone();
        c.observer.readout = mode;
        for rung in LADDER {
            let row = Row {
                rung: *rung,
                readout: readout_name(mode),
                measurements: measure_rung(&c, rung, &seeds)?,
            };
            each(&row);
            rows.push(row);
        }
    }
    Ok(rows)
}
