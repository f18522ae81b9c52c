//! `colorvision stiles-burch --run DIR`: the colour-matching functions of a trained cortex with
//! the primaries of Stiles & Burch (1955), 645.2 / 526.3 / 444.4 nm, against their measured 2°
//! curves (paper RS-08, Fig. 11; the matching itself is [`colorimetry::compare_stiles_burch`]).
//!
//! A correlation alone does not say how close "close" is: this eye's cones are not the human
//! standard observer's, so even a perfect cortex would not reproduce Stiles & Burch. Every
//! comparison is therefore made for four observers of the same light, in this order:
//! - `stockman_sharpe`: the human standard cone fundamentals (Stockman & Sharpe 2000, 2°) as
//!   the percept — what human cones give;
//! - `own_fundamentals`: this eye's own cone fundamentals (its classes, template, lens) as the
//!   percept, with no mosaic and no noise — the **ceiling** for any cortex on these cones;
//! - `oracle`: the oracle decoder through the real eye (the true lateral inhibition inverted,
//!   each class interpolated across the true mosaic; [`science::observer::oracle`]) — what the
//!   mosaic and the noise leave of the ceiling;
//! - `trained`: the learned cortex.
//!
//! Output: `OUT/<observer>/stiles_burch.{json,svg}` and `OUT/table.json` (one row per observer);
//! `OUT` is `DIR/stiles-burch/` for a run folder. "Of ceiling" is the trained cortex's r over
//! `own_fundamentals`' r, per channel.

use crate::cli::RunDirOptions;
use crate::run::error::RunError;
use crate::run::measurement_dir::measurement_dir;
use colorimetry::analytic::ConeObserver;
use colorimetry::{compare_stiles_burch, ConeTemplate, Observer, StilesBurchSettings};
use cortex::Cortex;
use retina::Retina;
use science::config::RunConfig;
use science::measure::{oracle_decoder, own_fundamentals};
use science::observer::{Decoder, EyeObserver};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// One observer's agreement with Stiles & Burch.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// `stockman_sharpe`, `own_fundamentals`, `oracle` or `trained`.
    pub observer: String,
    /// Pearson r of r̄, ḡ, b̄ against the tabulated curves.
    pub correlation: [f64; 3],
    /// RMSE of r̄, ḡ, b̄ after each channel's least-squares gain.
    pub rmse: [f64; 3],
}

/// The four comparisons (module docs) for `cortex` trained on the eye of `config`, written into
/// `out`; the rows in the module docs' order.
pub fn compare(config: &RunConfig, cortex: &Cortex, out: &Path) -> Result<Vec<Row>, RunError> {
    let retina = Retina::new(config.retina.clone())?;
    let human = human_standard(config)?;
    let own = own_fundamentals(&retina, config)?;
    let oracle = Decoder::Oracle(oracle_decoder(&retina, config, true)?);
    let oracle = EyeObserver::new(&retina, oracle, config.observer.clone());
    let trained = EyeObserver::cortex(&retina, cortex, config.observer.clone());
    let observers: [(&str, &dyn Observer); 4] = [
        ("stockman_sharpe", &human),
        ("own_fundamentals", &own),
        ("oracle", &oracle),
        ("trained", &trained),
    ];
    let settings = StilesBurchSettings {
        seed: config.cmf_sim.seed,
        ..StilesBurchSettings::default()
    };
    let mut rows = Vec::new();
    for (name, observer) in observers {
        let r = compare_stiles_burch(observer, &settings)?;
        crate::io::save_into(&out.join(name), |d| {
            Ok::<_, RunError>(r.save(d).map(|_| ())?)
        })?;
        rows.push(Row {
            observer: name.to_string(),
            correlation: std::array::from_fn(|c| r.channels[c].correlation),
            rmse: std::array::from_fn(|c| r.channels[c].rmse),
        });
    }
    crate::io::write_json(&out.join("table.json"), &rows)?;
    Ok(rows)
}

/// The human standard cone fundamentals (Stockman & Sharpe 2000, 2°) as an observer whose
/// percept is the cone excitations, on the eye's wavelength grid.
fn human_standard(config: &RunConfig) -> Result<ConeObserver, RunError> {
    let grid = config.retina.grid.grid()?;
    Ok(ConeObserver::new(
        &colorimetry::ConeClass::lms(),
        &ConeTemplate::StockmanSharpe2deg,
        &grid,
    )?)
}

/// The rows as a Markdown table, with the trained cortex's r as a fraction of the ceiling's.
pub fn markdown(rows: &[Row]) -> String {
    let mut s =
        String::from("| observer | r̄ r | ḡ r | b̄ r | RMSE r̄/ḡ/b̄ |\n|---|---|---|---|---|\n");
    for row in rows {
        let [r, g, b] = row.correlation;
        let [er, eg, eb] = row.rmse;
        s.push_str(&format!(
            "| {} | {r:.3} | {g:.3} | {b:.3} | {er:.3}/{eg:.3}/{eb:.3} |\n",
            row.observer
        ));
    }
    let find = |name: &str| rows.iter().find(|r| r.observer == name);
    if let (Some(t), Some(c)) = (find("trained"), find("own_fundamentals")) {
        let f: [f64; 3] = std::array::from_fn(|i| t.correlation[i] / c.correlation[i]);
        s.push_str(&format!(
            "\ntrained cortex's r as a fraction of the ceiling (own fundamentals): {:.2} / {:.2} / {:.2}\n",
            f[0], f[1], f[2]
        ));
    }
    s
}

/// `colorvision stiles-burch --run DIR`: [`compare`] on the run's last checkpoint, into `--out`
/// or `DIR/stiles-burch/` ([`crate::run::measurement_dir`]).
pub fn command(options: &RunDirOptions) -> Result<Vec<Row>, RunError> {
    crate::commands::refuse_settings_with_run(&options.common, "stiles-burch")?;
    let out = measurement_dir(&options.run, options.common.out.as_ref(), "stiles-burch")?;
    let lock = crate::run::lock::RunLock::acquire(&options.run)?;
    let (config, trainer, _) =
        crate::run::folder::load_run_step(&options.run, options.checkpoint_step)?;
    drop(lock);
    let rows = compare(&config, &trainer.cortex, &out)?;
    print!("{}", markdown(&rows));
    println!("wrote {}/", out.display());
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn correlations(observer: &ConeObserver) -> [f64; 3] {
        let r = compare_stiles_burch(observer, &StilesBurchSettings::default()).unwrap();
        std::array::from_fn(|c| r.channels[c].correlation)
    }

    /// The two cone-fundamental observers of `config`'s eye (scenes are not needed).
    fn fundamentals(mut config: RunConfig) -> [ConeObserver; 2] {
        config.retina.scenes.tiles = 1;
        let retina = Retina::new(config.retina.clone()).unwrap();
        let own = own_fundamentals(&retina, &config).unwrap();
        [human_standard(&config).unwrap(), own]
    }

    #[test]
    fn the_ceiling_is_the_eyes_own_fundamentals() {
        // An eye built with the human standard's fundamentals has the standard as its ceiling.
        let mut config = RunConfig::preset("tiny", "LMS").unwrap();
        config.retina.template = ConeTemplate::StockmanSharpe2deg;
        let [human, own] = fundamentals(config);
        let standard = correlations(&human);
        assert_eq!(correlations(&own), standard);
        // Stiles & Burch's CMFs are a linear transform of the standard fundamentals (up to
        // measurement error), so matching with those cones reproduces them closely.
        assert!(standard.iter().all(|&r| r > 0.95), "{standard:?}");
        // The default eye's cones (Carroll/Neitz templates, peaks 560/530/419 nm) are not the
        // standard's: its ceiling differs.
        let [_, own] = fundamentals(RunConfig::preset("tiny", "LMS").unwrap());
        assert_ne!(correlations(&own), standard);
    }

    #[test]
    fn the_table_gives_the_trained_cortex_as_a_fraction_of_the_ceiling() {
        let row = |observer: &str, r: f64| Row {
            observer: observer.into(),
            correlation: [r; 3],
            rmse: [0.1; 3],
        };
        let md = markdown(&[row("own_fundamentals", 0.8), row("trained", 0.6)]);
        assert!(md.contains("| trained | 0.600 | 0.600 | 0.600 |"), "{md}");
        assert!(
            md.contains("ceiling (own fundamentals): 0.75 / 0.75 / 0.75"),
            "{md}"
        );
    }
}
