//! What the paper reports for a run's settings: the colour dimensionality Kotani & Ng (ICLR 2025)
//! measured with CMF-SIM for the same retina, visual environment and baseline, so that a table of
//! runs (`colorvision gather`) shows the paper's figure beside the measured one.
//!
//! | settings | paper | where |
//! |---|---|---|
//! | one cone class (L, M or S) | 1 | §6, Fig. 4.1 |
//! | two classes (LM, LS, MS) | 2 | §6, Fig. 4.1–4.2 |
//! | three classes: LMS at any L:M:S ratio; MS after gene therapy adds L (replace, co-express, mix) | 3 | Fig. 3.3, Fig. 6.1, S-06 (Fig. 9), RS-08 |
//! | LMS + Q at the pigeon's 506 nm, any environment | 4 | S-07 (Fig. 10), Fig. 6.2 |
//! | LMS + Q at the human 545 nm: natural scenes, hue-sphere colours | 3 | S-07 (Fig. 10) |
//! | LMS + Q at the human 545 nm: idealised tetrachromatic colours | 4 | S-07 (Fig. 10) |
//! | no demosaicker (D = identity), any retina | 1 | S-05, Fig. 4.3 |
//! | Φ = identity (the percept is the ONS) | undefined: no colour constancy | S-05 |
//! | Φ = identity on cone activations (no lateral inhibition, no foveation) | 1 | S-05 |
//!
//! The same figures hold for a fresh cortex and for a trained trichromat's cortex continued on
//! the four-class eye (boosting 3-D → 4-D): Fig. 10's caption calls S-07's runs boosting "by
//! addition of a Q cone to trichromatic L, M, S cones", with human Q 4-D only with idealised
//! colours. Fig. 6.2 (natural scenes, 4-D after the boost) places its Q "between S and M" in the
//! §6 text — the pigeon's, 4 in Fig. 10 too — and "between M and L" in its caption; only the
//! caption's reading would make a boosted human Q 4-D in natural scenes, against Fig. 10, so the
//! text's is taken.
//!
//! Anything else — custom peaks, a fourth class at another wavelength, a cortex trained on cone
//! activations (a control of this project, not the paper's) — has no figure in the paper, and
//! [`reported_dimension`] returns `None` rather than guess one.

use colorimetry::cones::{HUMAN_Q_PEAK_NM, PIGEON_Q_PEAK_NM};
use cortex::config::Baseline;
use retina::scene::tetra::TetraEnvironment;
use retina::MosaicSpec;
use std::collections::BTreeMap;

/// What the paper's CMF-SIM measured.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reported {
    /// A colour dimensionality.
    Dimension(usize),
    /// No colour constancy, so no dimension (S-05's Φ = identity).
    Undefined,
}

impl Reported {
    /// Whether a CMF-SIM dimension (0: undefined, no colour constancy) is what the paper reports.
    pub fn agrees_with(self, dimension: usize) -> bool {
        match self {
            Reported::Dimension(d) => d == dimension,
            Reported::Undefined => dimension == 0,
        }
    }
}

impl std::fmt::Display for Reported {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Reported::Dimension(d) => write!(f, "{d}"),
            Reported::Undefined => write!(f, "undefined"),
        }
    }
}

/// The dimension the paper reports for a retina `cones`, with or without `lateral_inhibition`,
/// trained in `environment` (`None`: natural scenes) with the cortex `baseline` — from a fresh
/// cortex or continued from a trained one, the paper's figures being the same (table in the
/// module docs); `None` when the paper has no such experiment.
pub fn reported_dimension(
    cones: &MosaicSpec,
    lateral_inhibition: bool,
    environment: Option<TetraEnvironment>,
    baseline: Baseline,
) -> Option<Reported> {
    match baseline {
        Baseline::None => {}
        // The ONS itself has no colour constancy; the cone activations, with no lateral
        // inhibition to undo, are one-dimensional (S-05).
        Baseline::IdentityPercept if lateral_inhibition => return Some(Reported::Undefined),
        Baseline::IdentityPercept => return Some(Reported::Dimension(1)),
        Baseline::NoDemosaicker => return Some(Reported::Dimension(1)),
        Baseline::ConeActivationsAsOns => return None,
    }
    let classes = cones.class_names();
    let standard = |c: &String| ["L", "M", "S"].contains(&c.as_str());
    let extra: Vec<&String> = classes.iter().filter(|c| !standard(c)).collect();
    match (classes.len(), extra.as_slice()) {
        (1..=3, []) => Some(Reported::Dimension(classes.len())),
        (4, [q]) => {
            let peak_nm = cones.peaks_nm.iter().find(|(n, _)| n == *q)?.1;
            if peak_nm == PIGEON_Q_PEAK_NM {
                Some(Reported::Dimension(4))
            } else if peak_nm == HUMAN_Q_PEAK_NM {
                let idealised = environment == Some(TetraEnvironment::Idealised);
                Some(Reported::Dimension(if idealised { 4 } else { 3 }))
            } else {
                None
            }
        }
        _ => None,
    }
}

/// [`reported_dimension`] for a run's settings flattened to dotted keys (`cones`,
/// `retina.scenes.tetra.environment`, `cortex.baseline`, as `colorvision gather` reads them);
/// `None` also when a setting does not parse.
pub fn reported_for_settings(settings: &BTreeMap<String, String>) -> Option<Reported> {
    let cones = MosaicSpec::parse(settings.get("cones")?).ok()?;
    let environment = match settings.get("retina.scenes.tetra.environment") {
        None => None,
        Some(e) => Some(parse_enum::<TetraEnvironment>(e)?),
    };
    let baseline = match settings.get("cortex.baseline") {
        None => Baseline::None,
        Some(b) => parse_enum(b)?,
    };
    // `[retina.lateral_inhibition]` is absent from a config without it.
    let lateral_inhibition = (settings.keys()).any(|k| k.starts_with("retina.lateral_inhibition."));
    reported_dimension(&cones, lateral_inhibition, environment, baseline)
}

/// A unit enum variant from its name as the run's `config.toml` writes it.
fn parse_enum<T: serde::de::DeserializeOwned>(name: &str) -> Option<T> {
    toml::Value::String(name.to_string()).try_into().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reported(cones: &str, environment: Option<&str>, baseline: &str) -> Option<String> {
        let mut s = BTreeMap::from([
            ("cones".to_string(), cones.to_string()),
            ("cortex.baseline".to_string(), baseline.to_string()),
            (
                "retina.lateral_inhibition.sigma_centre_cells".into(),
                "0.15".into(),
            ),
        ]);
        if let Some(e) = environment {
            s.insert("retina.scenes.tetra.environment".into(), e.into());
        }
        reported_for_settings(&s).map(|r| r.to_string())
    }

    #[test]
    fn one_dimension_per_cone_class_up_to_three() {
        for (cones, d) in [
            ("L", "1"),
            ("S", "1"),
            ("LM", "2"),
            ("MS", "2"),
            ("LMS", "3"),
            ("LMS,lm=1", "3"),
            ("iid,L=1,M=1,S=1", "3"),
            ("MS+L_replace_M", "3"),
            ("MS+L_coexpress_M", "3"),
            ("MS+L_ratio_M@0.6", "3"),
        ] {
            assert_eq!(reported(cones, None, "none").as_deref(), Some(d), "{cones}");
        }
    }

    #[test]
    fn human_q_is_four_dimensional_only_with_idealised_colours() {
        for (environment, d) in [
            (None, "3"),
            (Some("HueSphere"), "3"),
            (Some("Idealised"), "4"),
        ] {
            assert_eq!(reported("LMSQ", environment, "none").as_deref(), Some(d));
            // The pigeon's Q, decorrelated from L, M and S, is 4-D in every environment.
            assert_eq!(
                reported("LMSQ,Q:506", environment, "none").as_deref(),
                Some("4")
            );
        }
        assert_eq!(
            reported("LMS+Q_coexpress_LMS,Q:506", None, "none").as_deref(),
            Some("4")
        );
    }

    #[test]
    fn a_trained_trichromat_boosted_has_the_figures_of_s07() {
        let continued = |cones: &str, environment: Option<&str>| {
            let mut s = BTreeMap::from([("cones".to_string(), cones.to_string())]);
            s.insert(
                "continued_from".into(), // as `colorvision gather` names it
                "trained @ 40000".into(),
            );
            if let Some(e) = environment {
                s.insert("retina.scenes.tetra.environment".into(), e.into());
            }
            reported_for_settings(&s).map(|r| r.to_string())
        };
        // Fig. 10 (boosting): human Q 4-D only with idealised colours, pigeon Q in every one.
        assert_eq!(continued("LMSQ", None).as_deref(), Some("3"));
        assert_eq!(continued("LMSQ", Some("HueSphere")).as_deref(), Some("3"));
        assert_eq!(continued("LMSQ", Some("Idealised")).as_deref(), Some("4"));
        assert_eq!(continued("LMSQ,Q:506", None).as_deref(), Some("4"));
        // Gene therapy continues a dichromat into a trichromat: 3, as from scratch.
        assert_eq!(continued("MS+L_replace_M", None).as_deref(), Some("3"));
    }

    #[test]
    fn a_measured_dimension_agrees_with_the_same_figure_and_undefined_with_zero() {
        assert!(Reported::Dimension(3).agrees_with(3));
        assert!(!Reported::Dimension(3).agrees_with(2));
        assert!(!Reported::Dimension(1).agrees_with(0));
        assert!(Reported::Undefined.agrees_with(0));
        assert!(!Reported::Undefined.agrees_with(1));
    }

    #[test]
    fn baselines_and_experiments_the_paper_did_not_run() {
        assert_eq!(
            reported("LMS", None, "no_demosaicker").as_deref(),
            Some("1")
        );
        assert_eq!(
            reported("LMS", None, "identity_percept").as_deref(),
            Some("undefined")
        );
        assert_eq!(reported("LMS", None, "cone_activations_as_ons"), None);
        // Φ = identity on the cone activations themselves (an eye without lateral inhibition).
        let cones_as_percept = BTreeMap::from([
            ("cones".to_string(), "LMS".to_string()),
            (
                "cortex.baseline".to_string(),
                "identity_percept".to_string(),
            ),
        ]);
        assert_eq!(
            reported_for_settings(&cones_as_percept).map(|r| r.to_string()),
            Some("1".into())
        );
        // A fourth class at another peak, or five classes: no figure in the paper.
        assert_eq!(reported("LMSQ,Q:600", None, "none"), None);
        assert_eq!(reported("L:560,S:419,X:600", None, "none"), None);
        // Settings that do not parse give no figure rather than a wrong one.
        assert_eq!(reported("not a mosaic", None, "none"), None);
        assert_eq!(reported("LMSQ", Some("Tropical"), "none"), None);
    }
}
