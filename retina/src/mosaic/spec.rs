//! Mosaic specifications: which cone classes, how they are arranged, which peaks.
//!
//! A [`MosaicSpec`] is parsed from a short string (the `--cones` argument of the CLI and the
//! `cones` field of a configuration). Grammar — comma-separated tokens:
//!
//! | string | meaning (authors' code, docs/references.md#cone-mosaic) |
//! |---|---|
//! | `LMS` | trichromat: L:M = 1.92:1 i.i.d., then S inserted on a sparse lattice |
//! | `L`, `M`, `S` | monochromat |
//! | `LM`, `LS`, `MS` | dichromats: tritanope (each S → L or M, ½), deuteranope (M → L), protanope (L → M) |
//! | `LMSQ` | tetrachromat: `LMS+Q_replace_L` (50 % of L become Q, human Q 545 nm) |
//! | `MS+L_replace_M` | gene therapy: 50 % of M cones become L |
//! | `MS+L_coexpress_M` | … express 0.5 L + 0.5 M |
//! | `MS+L_ratio_M@0.6` | … express r·L + (1−r)·M, r ~ U(0,1), affecting 60 % of M cones |
//! | `LMS+Q_coexpress_LMS` | boost: any cone, with probability ½, co-expresses Q |
//! | `LMSQ,Q:506` | peaks after the arrangement: pigeon Q (506 nm) |
//! | `LMS,lm=1` | L:M ratio 1:1 (paper RS-08) |
//! | `L:560,S:419` | classes with peaks; the arrangement follows from the names (here `LS`) |
//! | `iid,L=1,M=1,S=1` | custom ratios, every cell drawn i.i.d. (paper RS-08's 1:1:1) |
//!
//! Modifications are `<NEW>_<mode>_<TARGETS>[@fraction]` with mode `replace`, `coexpress` or
//! `ratio`; TARGETS lists one-letter class names; the fraction (probability that an eligible
//! cone is affected) defaults to 0.5, the official code's value (authors' code, docs/references.md#cone-mosaic; the paper says
//! ≈60 % for gene therapy, S-06).
//!
//! Default peaks (λmax, nm; authors' code, docs/references.md#cone-templates, paper S-02/S-07): L 560, M 530, S 419, Q 545.
//! Any other class name needs an explicit peak (`X:600`).

use colorimetry::cones::{ConeClass, HUMAN_Q_PEAK_NM, L_PEAK_NM, M_PEAK_NM, S_PEAK_NM};
use serde::{Deserialize, Serialize};

use crate::error::{Result, RetinaError};

/// L:M ratio of the trichromat mosaic (authors' code, docs/references.md#cone-mosaic, `generate_cone_mosaic.py`).
pub const DEFAULT_L_TO_M_RATIO: f64 = 1.92;
/// Side of the window (cells) in which no second S cone may lie (authors' code, docs/references.md#cone-mosaic: rows
/// `[i−3, i+3)` × cols `[j−3, j+3)`).
pub const DEFAULT_S_EXCLUSION_WINDOW_CELLS: usize = 6;
/// Probability that an eligible cone is affected by a modification (authors' code, docs/references.md#cone-mosaic: 0.5).
pub const DEFAULT_MODIFICATION_FRACTION: f64 = 0.5;

/// How the base classes are laid out before modifications.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Arrangement {
    /// The trichromat: L/M i.i.d. with `l_to_m_ratio`, S inserted greedily.
    Trichromat,
    /// A trichromat converted to the dichromat that keeps these two classes.
    Dichromat {
        /// The two remaining classes, e.g. `["L", "M"]`.
        keep: [String; 2],
    },
    /// Every cell is this class.
    Mono(String),
    /// Every cell drawn i.i.d. with these relative weights.
    Iid(Vec<(String, f64)>),
}

/// How an affected cone changes (authors' code, docs/references.md#cone-mosaic and paper S-06, Fig. 9).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Expression {
    /// The target opsin is replaced by the new one.
    Replace,
    /// Half target, half new (0.5/0.5).
    Coexpress,
    /// New fraction r ~ U(0,1), target 1 − r (spatially random ratios).
    Ratio,
}

/// Adds a class to some of the cones of the target classes.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Modification {
    /// Name of the class added.
    pub new_class: String,
    /// How it is expressed.
    pub expression: Expression,
    /// Classes whose cones are eligible.
    pub targets: Vec<String>,
    /// Probability that an eligible cone is affected.
    pub fraction: f64,
}

/// A parsed mosaic specification (see the module docs for the string grammar).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MosaicSpec {
    /// The original string.
    pub text: String,
    /// Base arrangement.
    pub arrangement: Arrangement,
    /// Modifications applied in order.
    pub modifications: Vec<Modification>,
    /// λmax (nm) per class name; defaults for L, M, S, Q plus overrides.
    pub peaks_nm: Vec<(String, f64)>,
    /// L:M ratio of the trichromat arrangement.
    pub l_to_m_ratio: f64,
    /// S exclusion window side, cells.
    pub s_exclusion_window_cells: usize,
}

/// Peaks accepted for a cone class, nm (vertebrate cone photopigments lie within).
pub const PEAK_RANGE_NM: std::ops::RangeInclusive<f64> = 300.0..=800.0;

fn default_peaks() -> Vec<(String, f64)> {
    vec![
        ("L".into(), L_PEAK_NM),
        ("M".into(), M_PEAK_NM),
        ("S".into(), S_PEAK_NM),
        ("Q".into(), HUMAN_Q_PEAK_NM),
    ]
}

fn bad(text: &str, message: impl Into<String>) -> RetinaError {
    RetinaError::setting(format!("cones `{text}`"), message)
}

fn parse_number(text: &str, what: &str, s: &str) -> Result<f64> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| bad(text, format!("{what} `{s}` is not a number")))?;
    if !v.is_finite() || v < 0.0 {
        return Err(bad(text, format!("{what} `{s}` must be finite and ≥ 0")));
    }
    Ok(v)
}

fn arrangement_from_names(
    text: &str,
    names: &[String],
) -> Result<(Arrangement, Vec<Modification>)> {
    let has = |c: &str| names.iter().any(|n| n == c);
    let known = names
        .iter()
        .all(|n| ["L", "M", "S", "Q"].contains(&n.as_str()));
    if !known {
        let ratios = names.iter().map(|n| (n.clone(), 1.0)).collect();
        return Ok((Arrangement::Iid(ratios), vec![]));
    }
    let base = |t: &str| parse_base(text, t);
    match (has("L"), has("M"), has("S"), has("Q")) {
        (true, true, true, false) => base("LMS"),
        (true, true, true, true) => base("LMSQ"),
        (true, true, false, false) => base("LM"),
        (true, false, true, false) => base("LS"),
        (false, true, true, false) => base("MS"),
        _ if names.len() == 1 => base(&names[0]),
        _ => Err(bad(
            text,
            "this set of classes has no standard arrangement; use `iid,X=w,…`",
        )),
    }
}

fn parse_base(text: &str, base: &str) -> Result<(Arrangement, Vec<Modification>)> {
    let dichromat = |a: &str, b: &str| Arrangement::Dichromat {
        keep: [a.to_string(), b.to_string()],
    };
    Ok(match base {
        "LMS" => (Arrangement::Trichromat, vec![]),
        "LMSQ" => (
            Arrangement::Trichromat,
            vec![Modification {
                new_class: "Q".into(),
                expression: Expression::Replace,
                targets: vec!["L".into()],
                fraction: DEFAULT_MODIFICATION_FRACTION,
            }],
        ),
        "LM" => (dichromat("L", "M"), vec![]),
        "LS" => (dichromat("L", "S"), vec![]),
        "MS" => (dichromat("M", "S"), vec![]),
        "L" | "M" | "S" | "Q" => (Arrangement::Mono(base.into()), vec![]),
        _ => {
            return Err(bad(
                text,
                format!(
                    "unknown base `{base}` (LMS, LMSQ, L, M, S, LM, LS, MS, iid, or X:nm list)"
                ),
            ))
        }
    })
}

/// Sets the peak of `NAME:nm` in `peaks`; returns the name.
fn set_peak(text: &str, peaks: &mut Vec<(String, f64)>, tok: &str) -> Result<String> {
    let (name, nm) = tok.split_once(':').expect("caller checked ':'");
    let name = name.trim().to_string();
    let nm = parse_number(text, "peak", nm)?;
    if name.is_empty() || nm <= 0.0 {
        return Err(bad(
            text,
            format!("peak `{tok}` needs a name and a positive nm"),
        ));
    }
    if !PEAK_RANGE_NM.contains(&nm) {
        return Err(bad(
            text,
            format!(
                "peak `{tok}` is outside {}–{} nm, the range of cone photopigments",
                PEAK_RANGE_NM.start(),
                PEAK_RANGE_NM.end()
            ),
        ));
    }
    peaks.retain(|(n, _)| *n != name);
    peaks.push((name.clone(), nm));
    Ok(name)
}

fn parse_modification(text: &str, m: &str) -> Result<Modification> {
    let (body, fraction) = match m.split_once('@') {
        Some((b, f)) => (b, parse_number(text, "fraction", f)?),
        None => (m, DEFAULT_MODIFICATION_FRACTION),
    };
    if fraction > 1.0 {
        return Err(bad(text, format!("fraction {fraction} is above 1")));
    }
    let parts: Vec<&str> = body.split('_').collect();
    if parts.len() != 3 || parts.iter().any(|p| p.is_empty()) {
        return Err(bad(
            text,
            format!("modification `{m}` is not NEW_mode_TARGETS (e.g. L_replace_M)"),
        ));
    }
    let expression = match parts[1] {
        "replace" => Expression::Replace,
        "coexpress" => Expression::Coexpress,
        "ratio" => Expression::Ratio,
        other => {
            return Err(bad(
                text,
                format!("mode `{other}` is not replace, coexpress or ratio"),
            ))
        }
    };
    Ok(Modification {
        new_class: parts[0].into(),
        expression,
        targets: parts[2].chars().map(|c| c.to_string()).collect(),
        fraction,
    })
}

impl MosaicSpec {
    /// Parse a mosaic string (grammar in the module docs).
    pub fn parse(text: &str) -> Result<MosaicSpec> {
        let t = text.trim();
        if t.is_empty() {
            return Err(bad(text, "empty"));
        }
        let tokens: Vec<&str> = t.split(',').map(str::trim).collect();
        let mut peaks = default_peaks();
        let mut l_to_m_ratio = DEFAULT_L_TO_M_RATIO;
        let (arrangement, mut modifications, rest) = if tokens[0].contains(':') {
            let mut names = Vec::new();
            for tok in &tokens {
                if !tok.contains(':') {
                    return Err(bad(text, format!("`{tok}` in a peak list is not NAME:nm")));
                }
                let name = set_peak(text, &mut peaks, tok)?;
                if names.contains(&name) {
                    return Err(bad(text, format!("class {name} listed twice")));
                }
                names.push(name);
            }
            let (a, m) = arrangement_from_names(text, &names)?;
            (a, m, &tokens[..0])
        } else if tokens[0] == "iid" {
            let mut ratios = Vec::new();
            let mut rest_start = tokens.len();
            for (i, tok) in tokens.iter().enumerate().skip(1) {
                match tok.split_once('=') {
                    Some((name, w)) => {
                        ratios.push((name.trim().to_string(), parse_number(text, "ratio", w)?))
                    }
                    None => {
                        rest_start = i;
                        break;
                    }
                }
            }
            if ratios.is_empty() || ratios.iter().all(|(_, w)| *w == 0.0) {
                return Err(bad(
                    text,
                    "iid needs at least one NAME=weight with weight > 0",
                ));
            }
            (Arrangement::Iid(ratios), vec![], &tokens[rest_start..])
        } else {
            let mut parts = tokens[0].split('+');
            let (a, mut m) = parse_base(text, parts.next().expect("split yields one part"))?;
            for p in parts {
                m.push(parse_modification(text, p)?);
            }
            (a, m, &tokens[1..])
        };
        for tok in rest {
            if tok.contains(':') {
                set_peak(text, &mut peaks, tok)?;
            } else if let Some(v) = tok.strip_prefix("lm=") {
                l_to_m_ratio = parse_number(text, "lm", v)?;
                if l_to_m_ratio <= 0.0 {
                    return Err(bad(text, "lm must be > 0"));
                }
            } else {
                return Err(bad(
                    text,
                    format!("unexpected token `{tok}` (NAME:nm or lm=ratio)"),
                ));
            }
        }
        let spec = MosaicSpec {
            text: t.to_string(),
            arrangement,
            modifications: std::mem::take(&mut modifications),
            peaks_nm: peaks,
            l_to_m_ratio,
            s_exclusion_window_cells: DEFAULT_S_EXCLUSION_WINDOW_CELLS,
        };
        for name in spec.class_names() {
            spec.class(&name)?;
        }
        spec.check_targets()?;
        Ok(spec)
    }

    /// Every modification must target classes the mosaic has at that point (a typo such as
    /// `MS+L_replace_Z` would otherwise leave a plain MS eye).
    fn check_targets(&self) -> Result<()> {
        let mut present: Vec<String> = match &self.arrangement {
            Arrangement::Trichromat => vec!["L".into(), "M".into(), "S".into()],
            Arrangement::Dichromat { keep } => keep.to_vec(),
            Arrangement::Mono(c) => vec![c.clone()],
            Arrangement::Iid(r) => r.iter().map(|(n, _)| n.clone()).collect(),
        };
        for m in &self.modifications {
            if let Some(t) = m.targets.iter().find(|t| !present.contains(t)) {
                return Err(bad(
                    &self.text,
                    format!(
                        "the modification adding {} targets class {t}, which the mosaic does \
                         not have (it has {})",
                        m.new_class,
                        present.join(", ")
                    ),
                ));
            }
            if !present.contains(&m.new_class) {
                present.push(m.new_class.clone());
            }
        }
        Ok(())
    }

    /// The cone class with this name and its peak. Error if the name has no peak.
    pub fn class(&self, name: &str) -> Result<ConeClass> {
        self.peaks_nm
            .iter()
            .find(|(n, _)| n == name)
            .map(|(n, p)| ConeClass::custom(n.clone(), *p))
            .ok_or_else(|| {
                bad(
                    &self.text,
                    format!("class {name} has no default peak; give it as {name}:nm"),
                )
            })
    }

    /// Every class name the arrangement and modifications can produce, in canonical order
    /// (L, M, S, Q first, then others in order of appearance).
    pub fn class_names(&self) -> Vec<String> {
        let mut names: Vec<String> = match &self.arrangement {
            Arrangement::Trichromat => vec!["L".into(), "M".into(), "S".into()],
            Arrangement::Dichromat { keep } => keep.to_vec(),
            Arrangement::Mono(c) => vec![c.clone()],
            Arrangement::Iid(r) => r.iter().map(|(n, _)| n.clone()).collect(),
        };
        for m in &self.modifications {
            if !names.contains(&m.new_class) {
                names.push(m.new_class.clone());
            }
        }
        canonical_order(names)
    }
}

/// Sort class names: L, M, S, Q first (in that order), then the rest as given.
pub fn canonical_order(mut names: Vec<String>) -> Vec<String> {
    let rank = |n: &String| {
        ["L", "M", "S", "Q"]
            .iter()
            .position(|c| c == n)
            .unwrap_or(usize::MAX)
    };
    names.sort_by_key(rank);
    names
}

#[cfg(test)]
mod tests;
