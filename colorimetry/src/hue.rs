//! Hue measures of colours in linear sRGB, through CIE 1931 XYZ (IEC 61966-2-1) to CIELAB with
//! the D65 white scaled to the 99th percentile of the colours' luminance Y (the scene white
//! after white balance): the dominant hue axis of a set of colours (paper Fig. 5.2) and the
//! hue-angle error of a percept against the true colours. Rows are `(m, 3)`, row-major; angles
//! are in degrees, `atan2(b*, a*)`.

/// The dominant hue axis of a set of colours (paper Fig. 5.2: a dichromat's Neural-Scope colours
/// lie on one axis through grey, blue–yellow for LS and MS, teal–pink for LM).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HueAxis {
    /// Direction of the axis in the CIELAB (a\*, b\*) plane, degrees in [0, 180): 90 is the
    /// yellow–blue axis (b\*), 0 the pink-red–green-teal axis (a\*).
    pub angle_deg: f64,
    /// Second over first eigenvalue of the (a\*, b\*) second-moment matrix about grey:
    /// 0 for colours on one line, 1 for no preferred axis.
    pub minor_to_major: f64,
    /// RMS chroma √(a\*² + b\*²).
    pub rms_chroma: f64,
}

/// [`HueAxis`] of linear-sRGB rows `(m, 3)`. Colours go through XYZ (IEC 61966-2-1) to CIELAB
/// with the D65 white scaled to the 99th percentile of the rows' luminance Y (the scene white
/// after white balance); the axis is the principal direction of `(a*, b*)` about grey
/// (uncentred second moments). `None` for fewer than 2 rows or no chroma (RMS chroma < 1e-6).
pub fn hue_axis(linear_srgb: &[f64]) -> Option<HueAxis> {
    assert_eq!(
        linear_srgb.len() % 3,
        0,
        "hue_axis: {} values are not rgb rows",
        linear_srgb.len()
    );
    let xyz: Vec<[f64; 3]> = linear_srgb
        .chunks_exact(3)
        .map(|c| crate::srgb::linear_srgb_to_xyz([c[0], c[1], c[2]]))
        .collect();
    if xyz.len() < 2 {
        return None;
    }
    let mut ys: Vec<f64> = xyz.iter().map(|v| v[1]).collect();
    ys.sort_by(f64::total_cmp);
    let white_y = ys[(ys.len() - 1) * 99 / 100];
    if !(white_y > 0.0) {
        return None;
    }
    let white = crate::srgb::linear_srgb_to_xyz([1.0, 1.0, 1.0]).map(|v| v * white_y);
    let (mut saa, mut sab, mut sbb) = (0.0, 0.0, 0.0);
    for v in &xyz {
        let lab = crate::cie::xyz_to_lab(v.map(|c| c.max(0.0)), white);
        saa += lab[1] * lab[1];
        sab += lab[1] * lab[2];
        sbb += lab[2] * lab[2];
    }
    let m = xyz.len() as f64;
    let (saa, sab, sbb) = (saa / m, sab / m, sbb / m);
    let trace = saa + sbb;
    // Chroma below 1e-6 (rounding of exact greys) has no axis.
    if !(trace > 1e-12) {
        return None;
    }
    let disc = ((saa - sbb).powi(2) / 4.0 + sab * sab).sqrt();
    let (major, minor) = (trace / 2.0 + disc, trace / 2.0 - disc);
    let angle = (0.5 * (2.0 * sab).atan2(saa - sbb))
        .to_degrees()
        .rem_euclid(180.0);
    Some(HueAxis {
        angle_deg: angle,
        minor_to_major: (minor / major).max(0.0),
        rms_chroma: trace.sqrt(),
    })
}

/// How far a percept's hues lie from the true ones ([`hue_error`]).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct HueError {
    /// Mean absolute hue-angle difference over the chromatic pixels, degrees (0: every hue
    /// right; 90: as far as unrelated hues are on average; a grey or one-axis percept of a
    /// full-colour scene lands near 45–90).
    pub mean_abs_deg: f64,
    /// The same per sector of true hue, `[0°, 60°)`, `[60°, 120°)`, … in CIELAB (0°: pinkish
    /// red, 90°: yellow, 180°: green-teal, 270°: blue); `None` where no pixel falls.
    pub per_sector_deg: [Option<f64>; 6],
    /// Chromatic pixels counted.
    pub pixels: usize,
}

/// The hue-angle error of `percept` against `truth`, both linear-sRGB rows `(m, 3)`: both go to
/// CIELAB with the D65 white scaled to the 99th percentile of the truth's luminance (as
/// [`hue_axis`]); over the pixels whose true chroma C*ab is at least `min_chroma`, the
/// absolute difference of the hue angles `atan2(b*, a*)`, wrapped to [0°, 180°]. `None` when no
/// pixel is chromatic enough.
pub fn hue_error(percept: &[f64], truth: &[f64], min_chroma: f64) -> Option<HueError> {
    assert_eq!(
        percept.len(),
        truth.len(),
        "hue_error: {} percept values for {} true ones",
        percept.len(),
        truth.len()
    );
    let to_xyz = |rows: &[f64]| -> Vec<[f64; 3]> {
        rows.chunks_exact(3)
            .map(|c| crate::srgb::linear_srgb_to_xyz([c[0], c[1], c[2]]).map(|v| v.max(0.0)))
            .collect()
    };
    let (p, t) = (to_xyz(percept), to_xyz(truth));
    let mut ys: Vec<f64> = t.iter().map(|v| v[1]).collect();
    ys.sort_by(f64::total_cmp);
    let white_y = *ys.get((ys.len().max(1) - 1) * 99 / 100)?;
    if !(white_y > 0.0) {
        return None;
    }
    let white = crate::srgb::linear_srgb_to_xyz([1.0, 1.0, 1.0]).map(|v| v * white_y);
    let (mut sum, mut sectors, mut count) = (0.0, [(0.0, 0usize); 6], 0usize);
    for (pv, tv) in p.iter().zip(&t) {
        let (lp, lt) = (
            crate::cie::xyz_to_lab(*pv, white),
            crate::cie::xyz_to_lab(*tv, white),
        );
        if lt[1].hypot(lt[2]) < min_chroma {
            continue;
        }
        let (hp, ht) = (lp[2].atan2(lp[1]), lt[2].atan2(lt[1]));
        let d = (hp - ht).to_degrees().rem_euclid(360.0);
        let d = d.min(360.0 - d);
        let sector = ((ht.to_degrees().rem_euclid(360.0) / 60.0) as usize).min(5);
        sum += d;
        sectors[sector].0 += d;
        sectors[sector].1 += 1;
        count += 1;
    }
    (count > 0).then(|| HueError {
        mean_abs_deg: sum / count as f64,
        per_sector_deg: sectors.map(|(s, n)| (n > 0).then(|| s / n as f64)),
        pixels: count,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    #[test]
    fn hue_axis_of_yellow_blue_colours_is_b_star_and_of_a_full_gamut_has_no_axis() {
        // Greys plus yellows and blues of several strengths: one axis near 90°.
        let mut rows = Vec::new();
        for k in 0..20 {
            let t = k as f64 / 20.0;
            rows.extend([0.5 + 0.4 * t, 0.5 + 0.4 * t, 0.5 - 0.4 * t]); // towards yellow
            rows.extend([0.5 - 0.3 * t, 0.5 - 0.3 * t, 0.5 + 0.4 * t]); // towards blue
        }
        // sRGB yellow has h_ab ≈ 102°, sRGB blue ≈ 306° (an axis at 126°): the axis lies between.
        let axis = hue_axis(&rows).unwrap();
        assert!(axis.angle_deg > 95.0 && axis.angle_deg < 130.0, "{axis:?}");
        assert!(axis.minor_to_major < 0.05, "{axis:?}");
        // Reds and greens: the a* axis (near 0° / 180°).
        let mut rows = Vec::new();
        for k in 0..20 {
            let t = k as f64 / 20.0;
            rows.extend([0.5 + 0.4 * t, 0.5 - 0.2 * t, 0.5]);
            rows.extend([0.5 - 0.3 * t, 0.5 + 0.3 * t, 0.5 - 0.1 * t]);
        }
        let axis = hue_axis(&rows).unwrap();
        let off = axis.angle_deg.min(180.0 - axis.angle_deg);
        assert!(off < 30.0, "{axis:?}");
        // Random colours: no preferred axis.
        let mut rng = rand::rngs::StdRng::seed_from_u64(3);
        let rows: Vec<f64> = (0..3000).map(|_| rng.random_range(0.05..1.0)).collect();
        let axis = hue_axis(&rows).unwrap();
        // (The sRGB cube itself is elongated in CIELAB: 0.26.)
        assert!(axis.minor_to_major > 0.15, "{axis:?}");
        // Greys only: no chroma, no axis.
        assert!(hue_axis(&[0.3, 0.3, 0.3, 0.6, 0.6, 0.6]).is_none());
    }

    /// Known answers of the hue error: a percept equal to the truth is 0° off; yellow seen as
    /// blue and blue as yellow is about 180° off, sorted into the true hues' sectors; greys
    /// below the chroma floor are not counted.
    #[test]
    fn hue_error_known_answers() {
        let (yellow, blue, grey) = ([0.9, 0.8, 0.05], [0.05, 0.1, 0.9], [0.5, 0.5, 0.5]);
        let truth: Vec<f64> = [yellow, blue, grey, [1.0, 1.0, 1.0]].concat();
        let same = hue_error(&truth, &truth, 10.0).unwrap();
        assert_eq!((same.mean_abs_deg, same.pixels), (0.0, 2));
        let swapped: Vec<f64> = [blue, yellow, grey, [1.0, 1.0, 1.0]].concat();
        let e = hue_error(&swapped, &truth, 10.0).unwrap();
        assert!(e.mean_abs_deg > 150.0, "{e:?}");
        assert!(
            e.per_sector_deg[1].is_some(),
            "yellow's hue lies in [60°, 120°): {e:?}"
        );
        assert!(
            hue_error(&[0.5; 6], &[0.5; 6], 10.0).is_none(),
            "greys: nothing to count"
        );
    }
}
