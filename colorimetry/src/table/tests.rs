//! Tests of spectral tables: parsing, interpolation, and errors that name the file, line and field.

use super::*;

const GOOD: &str = "# test table\nwavelength_nm,a,b\n400,1,2\n410,3,4\n430,5,8\n";

#[test]
fn parses_and_interpolates() {
    let t = SpectralTable::parse("t.csv", GOOD).unwrap();
    assert_eq!(t.columns, vec!["a", "b"]);
    assert_eq!(t.column("b").unwrap(), &[2.0, 4.0, 8.0]);
    assert_eq!(t.interpolate("a", 405.0).unwrap(), 2.0);
    assert_eq!(t.interpolate("b", 420.0).unwrap(), 6.0);
    assert!(t.interpolate("a", 399.0).is_err());
    let g = WavelengthGrid::range(400.0, 430.0, 15.0).unwrap();
    let r = t.resample(&g).unwrap();
    assert_eq!(r.column("b").unwrap(), &[2.0, 5.0, 8.0]);
    assert_eq!(provenance_line(GOOD), Some("test table"));
}

#[test]
fn resample_outside_names_the_table() {
    let t = SpectralTable::parse("t.csv", GOOD).unwrap();
    let g = WavelengthGrid::range(400.0, 700.0, 10.0).unwrap();
    let e = t.resample(&g).unwrap_err().to_string();
    assert!(e.contains("t.csv") && e.contains("700"), "{e}");
    let e = t.column("zz").unwrap_err().to_string();
    assert!(e.contains("zz") && e.contains("t.csv"), "{e}");
}

#[test]
fn errors_name_file_line_and_field() {
    let nan = "# x\nwavelength_nm,a,b\n400,1,2\n410,NaN,4\n";
    let e = SpectralTable::parse("nan.csv", nan)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("nan.csv") && e.contains("line 4") && e.contains("`a`"),
        "{e}"
    );
    assert!(SpectralTable::parse_allowing_nan("nan.csv", nan).is_ok());

    let dec = "wavelength_nm,a\n400,1\n400,2\n";
    let e = SpectralTable::parse("dec.csv", dec)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 3") && e.contains("wavelength_nm"), "{e}");

    let ragged = "wavelength_nm,a,b\n400,1,2\n410,3\n";
    let e = SpectralTable::parse("r.csv", ragged)
        .unwrap_err()
        .to_string();
    assert!(e.contains("line 3") && e.contains("ragged"), "{e}");

    let text = "wavelength_nm,a\n400,x\n";
    let e = SpectralTable::parse("s.csv", text).unwrap_err().to_string();
    assert!(e.contains("`x`") && e.contains("`a`"), "{e}");

    let e = SpectralTable::parse("h.csv", "lambda,a\n400,1\n")
        .unwrap_err()
        .to_string();
    assert!(e.contains("header"), "{e}");
}

#[test]
fn from_csv_file_reports_missing_file() {
    let e = SpectralTable::from_csv_file("/nonexistent/spectra.csv").unwrap_err();
    assert!(e.to_string().contains("/nonexistent/spectra.csv"));
}
