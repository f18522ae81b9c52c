//! Tests of mosaic specifications: named mosaics parse, bad strings are errors that name the string.

use super::*;

#[test]
fn named_mosaics_parse() {
    let s = MosaicSpec::parse("LMS").unwrap();
    assert_eq!(s.arrangement, Arrangement::Trichromat);
    assert_eq!(s.class_names(), ["L", "M", "S"]);
    let s = MosaicSpec::parse("LMSQ,Q:506").unwrap();
    assert_eq!(s.class("Q").unwrap().peak_nm, 506.0);
    assert_eq!(s.modifications[0].targets, ["L"]);
    let s = MosaicSpec::parse("MS+L_ratio_M@0.6").unwrap();
    assert_eq!(s.modifications[0].fraction, 0.6);
    assert_eq!(s.modifications[0].expression, Expression::Ratio);
    assert_eq!(s.class_names(), ["L", "M", "S"]);
    let s = MosaicSpec::parse("L:560,S:419").unwrap();
    assert_eq!(
        s.arrangement,
        Arrangement::Dichromat {
            keep: ["L".into(), "S".into()]
        }
    );
    let s = MosaicSpec::parse("L:560,M:550,S:419").unwrap();
    assert_eq!(s.class("M").unwrap().peak_nm, 550.0);
    let s = MosaicSpec::parse("iid,L=1,M=2,S=0.5").unwrap();
    assert!(matches!(s.arrangement, Arrangement::Iid(ref r) if r.len() == 3));
    let s = MosaicSpec::parse("LMS,lm=1").unwrap();
    assert_eq!(s.l_to_m_ratio, 1.0);
}

#[test]
fn bad_mosaic_strings_are_errors_naming_the_string() {
    for bad in [
        "",
        "XYZ",
        "LMS+Q_swap_L",
        "MS+L_replace_M@1.5",
        "LMS,foo",
        "iid,X=1",
    ] {
        let e = MosaicSpec::parse(bad).unwrap_err().to_string();
        assert!(e.contains("cones"), "{bad}: {e}");
    }
}
