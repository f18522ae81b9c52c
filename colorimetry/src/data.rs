//! Embedded measured tables (compiled into the binary with `include_str!`, so every program works
//! from any directory with no data folder). Each accessor parses its table once (`OnceLock`) and
//! returns a `&'static` reference. Provenance of every file: `colorimetry/data/README.md` and the
//! first (`#`) line of each file, which [`provenance`] returns.
//!
//! Units: CMFs and cone fundamentals are relative, per unit radiant energy, linear. Illuminants
//! are relative spectral power (100 at 560 nm). Reflectances are factors in 0–1. Optical
//! densities are log10 units.

use std::sync::OnceLock;

use crate::table::{provenance_line, SpectralTable};

macro_rules! embedded {
    ($(#[$doc:meta])* $fn_name:ident, $path:literal) => {
        embedded!(@impl $(#[$doc])* $fn_name, $path, SpectralTable::parse);
    };
    (nan $(#[$doc:meta])* $fn_name:ident, $path:literal) => {
        embedded!(@impl $(#[$doc])* $fn_name, $path, SpectralTable::parse_allowing_nan);
    };
    (@impl $(#[$doc:meta])* $fn_name:ident, $path:literal, $parser:path) => {
        $(#[$doc])*
        #[doc = concat!("\n\nFile: `colorimetry/data/", $path, "`.")]
        pub fn $fn_name() -> &'static SpectralTable {
            static CELL: OnceLock<SpectralTable> = OnceLock::new();
            CELL.get_or_init(|| {
                $parser($path, include_str!(concat!("../data/", $path)))
                    .unwrap_or_else(|e| panic!("embedded table is corrupt: {e}"))
            })
        }
    };
}

embedded!(
    /// CIE 1931 2° standard observer x̄ ȳ z̄ (columns `x_bar`, `y_bar`, `z_bar`), 360–830 nm, 1 nm.
    cie1931_xyz,
    "cmfs/cie1931_2deg_xyz_1nm.csv"
);
embedded!(
    /// CIE 1924 photopic V(λ) (column `V`), 360–830 nm, 1 nm.
    photopic_v,
    "cmfs/cie1924_photopic_v_1nm.csv"
);
embedded!(
    /// Stiles & Burch 1955 2° RGB CMFs (columns `r_bar`, `g_bar`, `b_bar`; primaries
    /// 645.2 / 526.3 / 444.4 nm), 390–730 nm, 5 nm.
    stiles_burch_1955,
    "cmfs/stiles_burch_1955_2deg_rgb_5nm.csv"
);
embedded!(
    /// Stockman & Sharpe 2000 2° cone fundamentals (columns `l_bar`, `m_bar`, `s_bar`), energy,
    /// linear, peak 1; s̄ = 0 above 615 nm. 390–830 nm, 1 nm.
    stockman_sharpe_2deg,
    "cmfs/stockman_sharpe_2000_2deg_lms_energy_linear_1nm.csv"
);
embedded!(
    /// Stockman & Sharpe 2000 10° cone fundamentals, 390–830 nm, 1 nm.
    stockman_sharpe_10deg,
    "cmfs/stockman_sharpe_2000_10deg_lms_energy_linear_1nm.csv"
);
embedded!(nan
    /// CIE 2006 physiological components at 1 nm, 390–830 nm: `log10_abs_L`, `log10_abs_M`,
    /// `log10_abs_S` (S is `NaN` above 615 nm), `ocular_media_od_32yr` (lens and ocular media
    /// optical density, the Stockman–Sharpe lens the official code uses), `macular_od_2deg`.
    /// Derived from the 0.1 nm CIE TC 1-97 table by keeping its integer-nm rows verbatim.
    ocular_media_density,
    "physiology/cie2006_lms_absorbance_ocular_macular_1nm.csv"
);
embedded!(
    /// CIE D65 (column `D65`), 360–830 nm, 1 nm, 100 at 560 nm.
    d65,
    "illuminants/cie_d65_1nm.csv"
);
embedded!(
    /// CIE D50 (column `D50`), 300–780 nm, 5 nm, 100 at 560 nm.
    d50,
    "illuminants/cie_d50_5nm.csv"
);
embedded!(
    /// CIE illuminant A (column `A`), 360–830 nm, 1 nm.
    illuminant_a,
    "illuminants/cie_a_1nm.csv"
);
embedded!(
    /// CIE daylight basis S0, S1, S2 (columns `S0`, `S1`, `S2`), 300–830 nm, 5 nm.
    daylight_basis,
    "illuminants/cie_daylight_components_s0_s1_s2_5nm.csv"
);
embedded!(
    /// CIE equal-energy illuminant E (column `E`, 100 everywhere), 360–830 nm, 5 nm.
    illuminant_e,
    "illuminants/cie_e_5nm.csv"
);
embedded!(
    /// 1269 matte Munsell chips (columns `M0000`…`M1268`), 380–800 nm, 1 nm.
    munsell,
    "reflectances/munsell1269_matt_1nm.csv"
);
embedded!(
    /// IES TM-30-15 4880 real-object reflectances (columns `R0001`…`R4880`), 380–780 nm, 5 nm.
    /// Duplicates exist; [`iestm30_unique_indices`] lists the 2696 distinct ones.
    iestm30,
    "reflectances/iestm30_r4880_5nm.csv"
);
embedded!(
    /// CIE 224:2017 colour evaluation samples CES01…CES99, 360–830 nm, 1 nm.
    ces99,
    "reflectances/cie224_2017_ces99_1nm.csv"
);
embedded!(
    /// Macbeth ColorChecker, 24 patches measured by Ohta (ISO 17321-1), 380–780 nm, 5 nm.
    /// Columns are the patch names (`dark skin`, …, `black 2 (1.5 D)`).
    colorchecker_ohta,
    "reflectances/colorchecker_ohta_5nm.csv"
);
embedded!(
    /// ColorChecker Classic, BabelColor average of 30 charts, 380–730 nm, 10 nm.
    colorchecker_babelcolor,
    "reflectances/colorchecker_babelcolor_average_10nm.csv"
);

const IESTM30_UNIQUE: &str =
    include_str!("../data/reflectances/iestm30_r4880_unique2696_indices.csv");
const SRGB_CONSTANTS: &str = include_str!("../data/colorimetry/srgb_constants.csv");
const SRGB_MATRICES: &str = include_str!("../data/colorimetry/srgb_matrices.csv");
const MUNSELL_NOTATION: &str = include_str!("../data/reflectances/munsell1269_notation.csv");

/// The 2696 0-based column indices of [`iestm30`] that are distinct reflectances (luxpy).
pub fn iestm30_unique_indices() -> &'static [usize] {
    static CELL: OnceLock<Vec<usize>> = OnceLock::new();
    CELL.get_or_init(|| {
        data_lines(IESTM30_UNIQUE)
            .skip(1)
            .map(|l| l.parse().expect("embedded index file is valid"))
            .collect()
    })
}

/// One row of the Munsell notation table: index (column `M<index>` of [`munsell`]), hue, value,
/// chroma and hue angle (degrees).
#[derive(Debug, Clone, PartialEq)]
pub struct MunsellNotation {
    /// Column index in [`munsell`].
    pub index: usize,
    /// Munsell hue, e.g. `2.5R`.
    pub hue: String,
    /// Munsell value (lightness).
    pub value: f64,
    /// Munsell chroma.
    pub chroma: f64,
    /// Hue angle, degrees.
    pub hue_deg: f64,
}

/// Munsell notation for the 1269 chips of [`munsell`].
pub fn munsell_notation() -> &'static [MunsellNotation] {
    static CELL: OnceLock<Vec<MunsellNotation>> = OnceLock::new();
    CELL.get_or_init(|| {
        data_lines(MUNSELL_NOTATION)
            .skip(1)
            .map(|l| {
                let f: Vec<&str> = l.split(',').collect();
                let num = |i: usize| f[i].trim().parse::<f64>().expect("embedded notation");
                MunsellNotation {
                    index: f[0].trim().parse().expect("embedded notation"),
                    hue: f[1].trim().to_string(),
                    value: num(2),
                    chroma: num(3),
                    hue_deg: num(4),
                }
            })
            .collect()
    })
}

/// A value of `colorimetry/data/colorimetry/srgb_constants.csv` by key (e.g. `oetf_scale`,
/// `d65_X_1nm_cie1931`), or `None` for an unknown key.
pub fn srgb_constant(key: &str) -> Option<f64> {
    data_lines(SRGB_CONSTANTS).skip(1).find_map(|l| {
        let (k, v) = l.split_once(',')?;
        (k.trim() == key).then(|| v.trim().parse().expect("embedded constants are numbers"))
    })
}

/// A 3×3 matrix (row-major, rows as in the file) of
/// `colorimetry/data/colorimetry/srgb_matrices.csv`, e.g. `xyz_to_linear_srgb_derived`,
/// `linear_srgb_to_xyz_iec`. `None` for an unknown name.
pub fn srgb_matrix(name: &str) -> Option<[[f64; 3]; 3]> {
    let rows: Vec<[f64; 3]> = data_lines(SRGB_MATRICES)
        .skip(1)
        .filter_map(|l| {
            let f: Vec<&str> = l.split(',').map(str::trim).collect();
            (f[0] == name).then(|| {
                let p = |i: usize| f[i].parse::<f64>().expect("embedded matrix");
                [p(2), p(3), p(4)]
            })
        })
        .collect();
    (rows.len() == 3).then(|| [rows[0], rows[1], rows[2]])
}

/// The provenance line of an embedded file, by its path under `colorimetry/data/`.
pub fn provenance(path: &str) -> Option<&'static str> {
    let text = match path {
        "cmfs/cie1931_2deg_xyz_1nm.csv" => include_str!("../data/cmfs/cie1931_2deg_xyz_1nm.csv"),
        "cmfs/stiles_burch_1955_2deg_rgb_5nm.csv" => {
            include_str!("../data/cmfs/stiles_burch_1955_2deg_rgb_5nm.csv")
        }
        "physiology/cie2006_lms_absorbance_ocular_macular_1nm.csv" => {
            include_str!("../data/physiology/cie2006_lms_absorbance_ocular_macular_1nm.csv")
        }
        "colorimetry/srgb_constants.csv" => SRGB_CONSTANTS,
        "colorimetry/srgb_matrices.csv" => SRGB_MATRICES,
        "reflectances/iestm30_r4880_unique2696_indices.csv" => IESTM30_UNIQUE,
        "reflectances/munsell1269_notation.csv" => MUNSELL_NOTATION,
        _ => return None,
    };
    provenance_line(text)
}

fn data_lines(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_small_table_parses_with_expected_columns() {
        assert_eq!(cie1931_xyz().columns, vec!["x_bar", "y_bar", "z_bar"]);
        assert_eq!(cie1931_xyz().n_wavelengths(), 471);
        assert_eq!(stiles_burch_1955().columns, vec!["r_bar", "g_bar", "b_bar"]);
        assert_eq!(stockman_sharpe_2deg().columns.len(), 3);
        assert_eq!(stockman_sharpe_10deg().columns.len(), 3);
        assert_eq!(photopic_v().columns, vec!["V"]);
        let od = ocular_media_density();
        assert_eq!(od.n_wavelengths(), 441);
        // authors' code, docs/references.md#cone-templates: lens density 1.7649 at 400, 0.724 at 420, 0.263 at 450
        assert!((od.interpolate("ocular_media_od_32yr", 400.0).unwrap() - 1.7649).abs() < 1e-9);
        assert!((od.interpolate("ocular_media_od_32yr", 420.0).unwrap() - 0.724).abs() < 1e-3);
        assert!((od.interpolate("ocular_media_od_32yr", 450.0).unwrap() - 0.263).abs() < 1e-3);
        assert_eq!(d65().interpolate("D65", 560.0).unwrap(), 100.0);
        assert_eq!(illuminant_a().interpolate("A", 560.0).unwrap(), 100.0);
        assert_eq!(daylight_basis().columns, vec!["S0", "S1", "S2"]);
        assert_eq!(illuminant_e().column("E").unwrap()[0], 100.0);
        assert_eq!(colorchecker_ohta().columns.len(), 24);
        assert_eq!(colorchecker_babelcolor().columns.len(), 24);
        assert_eq!(ces99().columns.len(), 99);
    }

    #[test]
    fn reflectance_sets_have_documented_sizes_and_range() {
        assert_eq!(munsell().columns.len(), 1269);
        assert_eq!(munsell_notation().len(), 1269);
        assert_eq!(iestm30().columns.len(), 4880);
        let idx = iestm30_unique_indices();
        assert_eq!(idx.len(), 2696);
        assert!(idx.iter().all(|&i| i < 4880));
        for t in [munsell(), ces99(), colorchecker_ohta()] {
            for col in &t.values {
                assert!(col.iter().all(|&v| (0.0..=1.0).contains(&v)), "{}", t.name);
            }
        }
    }

    #[test]
    fn srgb_constants_and_matrices_are_readable() {
        assert_eq!(srgb_constant("oetf_scale"), Some(1.055));
        assert_eq!(srgb_constant("nope"), None);
        let m = srgb_matrix("xyz_to_linear_srgb_iec").unwrap();
        assert_eq!(m[0], [3.2406, -1.5372, -0.4986]);
        assert!(srgb_matrix("linear_srgb_to_xyz_derived").is_some());
        assert!(srgb_matrix("nope").is_none());
        assert!(provenance("colorimetry/srgb_matrices.csv")
            .unwrap()
            .contains("IEC 61966-2-1"));
    }
}
