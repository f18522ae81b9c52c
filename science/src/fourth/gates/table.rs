//! The gates' table: markdown and CSV of [`GateRow`]s, one line per row.

use super::GateRow;
use retina::scene::q_from_lms::QFromLms;

/// Markdown table header of [`markdown_row`].
pub const MARKDOWN_HEADER: &str = "| eye | cones | scenes | balance | Q replaced | tiles | own share within | own share across | own var within | own var across | photon noise var | within / noise | across / noise | ONS across / noise | demosaic var | across / demosaic |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|";

/// CSV header of [`csv_row`].
pub const CSV_HEADER: &str = "eye,cones_per_side,cones,scenes,white_balance,q_from_lms,tiles,own_share_within,own_share_across,own_var_within,own_var_across,q_var,photon_noise_var,own_over_noise,ons_own_over_noise,demosaic_var,own_over_demosaic,seconds";

fn replaced(q: Option<QFromLms>) -> &'static str {
    match q {
        None => "no",
        Some(QFromLms::BeforeBalance) => "before balance",
        Some(QFromLms::AfterBalance) => "after balance",
    }
}

/// A share as a percentage with three significant digits.
fn percent(x: f64) -> String {
    let p = 100.0 * x;
    match p.abs() {
        v if !v.is_finite() => "—".into(),
        v if v >= 10.0 => format!("{p:.1} %"),
        v if v >= 1.0 => format!("{p:.2} %"),
        v if v >= 1e-3 => format!("{p:.3} %"),
        _ => format!("{p:.1e} %"),
    }
}

/// A variance or ratio with three significant digits.
fn sci(x: f64) -> String {
    if !x.is_finite() {
        return "—".into();
    }
    if x == 0.0 || (0.01..1000.0).contains(&x.abs()) {
        format!("{x:.3}")
    } else {
        format!("{x:.2e}")
    }
}

/// One markdown line.
pub fn markdown_row(r: &GateRow) -> String {
    format!(
        "| {} ({}²) | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
        r.eye,
        r.cones_per_side,
        r.case.cones,
        r.case.scenes.name(),
        if r.case.white_balance { "on" } else { "off" },
        replaced(r.case.q_from_lms),
        r.tiles,
        percent(r.own.within),
        percent(r.own.across),
        sci(r.own.within_residual_var),
        sci(r.own.across_residual_var),
        sci(r.photon_noise_var),
        sci(r.own.within_residual_var / r.photon_noise_var),
        sci(r.own.across_residual_var / r.photon_noise_var),
        sci(r.ons_own_over_noise),
        sci(r.demosaic_var),
        sci(r.own.across_residual_var / r.demosaic_var),
    )
}

/// One CSV line (full precision).
pub fn csv_row(r: &GateRow) -> String {
    format!(
        "{},{},\"{}\",{},{},{},{},{},{},{},{},{},{},{},{},{},{},{:.1}",
        r.eye,
        r.cones_per_side,
        r.case.cones,
        r.case.scenes.name(),
        r.case.white_balance,
        replaced(r.case.q_from_lms),
        r.tiles,
        r.own.within,
        r.own.across,
        r.own.within_residual_var,
        r.own.across_residual_var,
        r.own.q_var,
        r.photon_noise_var,
        r.own.across_residual_var / r.photon_noise_var,
        r.ons_own_over_noise,
        r.demosaic_var,
        r.own.across_residual_var / r.demosaic_var,
        r.seconds
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_keep_three_significant_digits() {
        assert_eq!(percent(0.2512), "25.1 %");
        assert_eq!(percent(0.0063), "0.630 %");
        assert_eq!(percent(f64::NAN), "—");
        assert_eq!(sci(1.234e-5), "1.23e-5");
        assert_eq!(sci(12.345), "12.345");
        assert_eq!(CSV_HEADER.split(',').count(), 18);
        assert_eq!(
            MARKDOWN_HEADER.lines().next().unwrap().matches('|').count(),
            17
        );
    }
}
