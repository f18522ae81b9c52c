use super::*;
use crate::scene::tests::lms_plus;
use colorimetry::{sensitivities, ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::SeedableRng;

fn sphere(classes: &[ConeClass]) -> HueSphere {
    let g = WavelengthGrid::default();
    let f = sensitivities(classes, &ConeTemplate::default(), &g).unwrap();
    HueSphere::new(&Projector::cones(&f), classes.len()).unwrap()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[test]
fn each_colour_reaches_furthest_along_its_hue() {
    let hs = sphere(&lms_plus(ConeClass::human_q()));
    let mut rng = StdRng::seed_from_u64(7);
    let n = WavelengthGrid::default().len();
    let hues: Vec<Vec<f64>> = (0..40).map(|_| hs.random_hue(&mut rng)).collect();
    let optimal: Vec<Vec<f64>> = hues.iter().map(|d| hs.reflectance(d)).collect();
    // Rivals: uniform noise, random 0/1 band patterns, and every other hue's optimum.
    let mut rivals: Vec<Vec<f64>> = (0..500)
        .map(|_| (0..n).map(|_| rng.random::<f64>()).collect())
        .collect();
    rivals.extend((0..500).map(|_| {
        let (a, b) = (rng.random_range(0..n), rng.random_range(0..n));
        (0..n)
            .map(|l| f64::from(u8::from((a.min(b)..=a.max(b)).contains(&l))))
            .collect()
    }));
    rivals.extend(optimal.iter().cloned());
    for (d, r) in hues.iter().zip(&optimal) {
        assert!(
            (d.iter().sum::<f64>()).abs() < 1e-12,
            "hue not chromatic: {d:?}"
        );
        assert!((dot(d, d) - 1.0).abs() < 1e-12, "hue not unit: {d:?}");
        let best = dot(d, &hs.colour(r));
        assert!(
            best > 0.0,
            "an optimal colour must go along its hue: {best}"
        );
        for x in &rivals {
            let v = dot(d, &hs.colour(x));
            assert!(v <= best + 1e-12, "a rival reaches further: {v} > {best}");
        }
        // The check can fail: switching one wavelength off lowers the reach.
        let l = r.iter().position(|&v| v == 1.0).unwrap();
        let mut worse = r.clone();
        worse[l] = 0.0;
        assert!(dot(d, &hs.colour(&worse)) < best);
    }
}

#[test]
fn a_dichromat_has_two_complementary_hues() {
    let hs = sphere(&[ConeClass::l(), ConeClass::s()]);
    let lib = hs.library(200, &mut StdRng::seed_from_u64(1));
    let mut distinct: Vec<Vec<f64>> = Vec::new();
    for s in &lib.spectra {
        if !distinct.contains(s) {
            distinct.push(s.clone());
        }
    }
    assert_eq!(distinct.len(), 2, "a dichromat's hue sphere is two points");
    assert!(distinct[0]
        .iter()
        .zip(&distinct[1])
        .all(|(a, b)| a + b == 1.0));
}

/// RMS residual of the fourth class regressed on the first three (with intercept) over
/// `colours`, relative to the fourth class's standard deviation: the part of the colours only a
/// tetrachromat sees.
fn fourth_class_residual(colours: &[Vec<f64>]) -> f64 {
    let rows: Vec<[f64; 4]> = colours.iter().map(|c| [c[0], c[1], c[2], 1.0]).collect();
    let mut ata = [[0.0; 4]; 4];
    let mut atb = [0.0; 4];
    for (r, c) in rows.iter().zip(colours) {
        for i in 0..4 {
            atb[i] += r[i] * c[3];
            for j in 0..4 {
                ata[i][j] += r[i] * r[j];
            }
        }
    }
    let beta = solve4(ata, atb);
    let m = colours.iter().map(|c| c[3]).sum::<f64>() / colours.len() as f64;
    let (mut res, mut var) = (0.0, 0.0);
    for (r, c) in rows.iter().zip(colours) {
        res += (c[3] - dot(r, &beta)).powi(2);
        var += (c[3] - m).powi(2);
    }
    (res / var).sqrt()
}

fn solve4(mut a: [[f64; 4]; 4], mut b: [f64; 4]) -> [f64; 4] {
    for i in 0..4 {
        let p = (i..4)
            .max_by(|&x, &y| a[x][i].abs().total_cmp(&a[y][i].abs()))
            .unwrap();
        a.swap(i, p);
        b.swap(i, p);
        for r in i + 1..4 {
            let f = a[r][i] / a[i][i];
            for c in i..4 {
                a[r][c] -= f * a[i][c];
            }
            b[r] -= f * b[i];
        }
    }
    let mut x = [0.0; 4];
    for i in (0..4).rev() {
        x[i] = (b[i] - (i + 1..4).map(|c| a[i][c] * x[c]).sum::<f64>()) / a[i][i];
    }
    x
}

#[test]
fn a_tetrachromat_hue_sphere_holds_colours_a_trichromat_confuses() {
    let g = WavelengthGrid::default();
    let natural = ReflectanceLibrary::measured(&g).unwrap();
    for q in [ConeClass::human_q(), ConeClass::pigeon_q()] {
        let hs = sphere(&lms_plus(q.clone()));
        let lib = hs.library(2000, &mut StdRng::seed_from_u64(3));
        let hue: Vec<_> = lib.spectra.iter().map(|r| hs.colour(r)).collect();
        let nat: Vec<_> = natural.spectra.iter().map(|r| hs.colour(r)).collect();
        let (h, n) = (fourth_class_residual(&hue), fourth_class_residual(&nat));
        eprintln!(
            "{}: Q not predicted by L, M, S: hue sphere {h:.4}, natural {n:.4}",
            q.name
        );
        assert!(h > n, "{}: hue sphere {h} vs natural {n}", q.name);
    }
    // Known answer: a fourth class that copies L adds nothing a trichromat lacks.
    let copy = sphere(&lms_plus(ConeClass::custom("L2", ConeClass::l().peak_nm)));
    let lib = copy.library(500, &mut StdRng::seed_from_u64(4));
    let colours: Vec<_> = lib.spectra.iter().map(|r| copy.colour(r)).collect();
    assert!(fourth_class_residual(&colours) < 1e-6);
}

#[test]
fn observers_get_their_own_hue_spheres_and_a_monochromat_none() {
    let human = sphere(&lms_plus(ConeClass::human_q()));
    let pigeon = sphere(&lms_plus(ConeClass::pigeon_q()));
    let a = human.library(100, &mut StdRng::seed_from_u64(5));
    let b = pigeon.library(100, &mut StdRng::seed_from_u64(5));
    let differ = a
        .spectra
        .iter()
        .zip(&b.spectra)
        .filter(|(x, y)| x != y)
        .count();
    assert!(differ > 10, "only {differ} of 100 differ");
    let g = WavelengthGrid::default();
    let f = sensitivities(&[ConeClass::l()], &ConeTemplate::default(), &g).unwrap();
    let err = HueSphere::new(&Projector::cones(&f), 1).unwrap_err();
    assert!(
        err.to_string().contains("scenes.tetra.environment"),
        "{err}"
    );
}
