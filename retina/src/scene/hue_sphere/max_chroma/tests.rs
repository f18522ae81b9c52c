use super::*;
use crate::scene::hue_sphere::HueRule;
use crate::scene::tests::lms_plus;
use crate::scene::Projector;
use colorimetry::{sensitivities, ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;

fn sphere(classes: &[ConeClass]) -> HueSphere {
    let g = WavelengthGrid::default();
    let f = sensitivities(classes, &ConeTemplate::default(), &g).unwrap();
    HueSphere::new(&Projector::cones(&f), classes.len()).unwrap()
}

fn pigeon() -> HueSphere {
    sphere(&lms_plus(ConeClass::pigeon_q()))
}

/// A random direction orthogonal to `(1, …, 1)`, not normalised.
fn chromatic_direction(k: usize, rng: &mut StdRng) -> Vec<f64> {
    let d: Vec<f64> = (0..k).map(|_| rng.sample(StandardNormal)).collect();
    let mean = d.iter().sum::<f64>() / k as f64;
    d.iter().map(|v| v - mean).collect()
}

#[test]
fn the_max_basis_maps_its_bands_to_unit_vectors_and_the_white_to_ones() {
    let hs = pigeon();
    let hues = MaxChromaHues::new(&hs).unwrap();
    let (k, n) = (hs.k(), hs.grid.len());
    assert_eq!(hues.cuts.len(), k - 1);
    assert!(hues.cuts.windows(2).all(|w| w[0] < w[1]), "{:?}", hues.cuts);
    let edges: Vec<usize> = [vec![0], hues.cuts.clone(), vec![n]].concat();
    let apply = |colour: &[f64]| -> Vec<f64> {
        (0..k)
            .map(|i| (0..k).map(|c| hues.basis[i * k + c] * colour[c]).sum())
            .collect()
    };
    let white = apply(&hs.colour(&vec![1.0; n]));
    assert!(white.iter().all(|v| (v - 1.0).abs() < 1e-9), "{white:?}");
    for j in 0..k {
        let band: Vec<f64> = (0..n)
            .map(|l| f64::from(u8::from((edges[j]..edges[j + 1]).contains(&l))))
            .collect();
        let x = apply(&hs.colour(&band));
        for (i, v) in x.iter().enumerate() {
            let want = f64::from(u8::from(i == j));
            assert!((v - want).abs() < 1e-9, "band {j}: {x:?}");
        }
    }
    // No other cut set spans a larger volume (the search is exhaustive; spot-check it).
    let volume = |cuts: &[usize]| {
        let e: Vec<usize> = [vec![0], cuts.to_vec(), vec![n]].concat();
        let m: Vec<f64> = (0..k * k)
            .map(|cj| {
                (e[cj % k]..e[cj % k + 1])
                    .map(|l| hs.weights[cj / k][l])
                    .sum()
            })
            .collect();
        determinant(m).abs()
    };
    let best = volume(&hues.cuts);
    let mut rng = StdRng::seed_from_u64(3);
    for _ in 0..500 {
        let mut cuts: Vec<usize> = (0..k - 1).map(|_| rng.random_range(1..n)).collect();
        cuts.sort_unstable();
        cuts.dedup();
        if cuts.len() == k - 1 {
            assert!(
                volume(&cuts) <= best * (1.0 + 1e-12),
                "{cuts:?} beats {:?}",
                hues.cuts
            );
        }
    }
}

#[test]
fn each_colour_lies_on_its_hue_as_far_out_as_any_surface_reaches() {
    for hs in [
        pigeon(),
        sphere(&[ConeClass::l(), ConeClass::m(), ConeClass::s()]),
    ] {
        let hues = MaxChromaHues::new(&hs).unwrap();
        let k = hs.k();
        let mut rng = StdRng::seed_from_u64(11);
        for _ in 0..40 {
            let d = hs.random_hue(&mut rng);
            let r = hues.reflectance(&d);
            assert!(r.iter().all(|v| (0.0..=1.0).contains(v)), "{r:?}");
            let (t, normal, _) = hues.reach(&d);
            assert!(t > 0.0 && dot(&normal, &d) > 0.0);
            // The surface's chroma is t·d: on the hue's ray, at the reach.
            let chroma = hues.chroma_of(&hs.colour(&r));
            for c in 0..k {
                assert!(
                    (chroma[c] - t * d[c]).abs() < 1e-9 * t,
                    "{chroma:?} vs {t}·{d:?}"
                );
            }
            // No surface reaches further: every direction u with u·d > 0 bounds the reach by
            // h(u) / (u·d), so a t above the true reach would break one of these.
            for _ in 0..2000 {
                let u = chromatic_direction(k, &mut rng);
                let along = dot(&u, &d);
                let support = 0.5 * hues.chroma.iter().map(|p| dot(&u, p).abs()).sum::<f64>();
                assert!(
                    support / along.abs() >= t * (1.0 - 1e-12),
                    "{u:?} bounds below {t}"
                );
            }
            // The check can fail: a tenth further out, the facet's own bound is broken.
            let support = 0.5
                * hues
                    .chroma
                    .iter()
                    .map(|p| dot(&normal, p).abs())
                    .sum::<f64>();
            assert!(support / dot(&normal, &d) < 1.1 * t);
        }
    }
}

#[test]
fn a_dichromat_has_two_colours_one_on_each_side_of_grey() {
    let hs = sphere(&[ConeClass::l(), ConeClass::s()]);
    let hues = MaxChromaHues::new(&hs).unwrap();
    let r_plus = hues.reflectance(&[0.5f64.sqrt(), -(0.5f64.sqrt())]);
    let r_minus = hues.reflectance(&[-(0.5f64.sqrt()), 0.5f64.sqrt()]);
    let (cp, cm) = (
        hues.chroma_of(&hs.colour(&r_plus)),
        hues.chroma_of(&hs.colour(&r_minus)),
    );
    assert!(cp[0] > 0.0 && cm[0] < 0.0, "{cp:?} {cm:?}");
    // The zonotope is symmetric about grey: the two reaches are equal.
    assert!((cp[0] + cm[0]).abs() < 1e-9, "{cp:?} {cm:?}");
}

/// Q's variance over `colours` that an affine fit from L, M, S leaves, as a fraction.
fn q_own_share(colours: &[Vec<f64>]) -> f64 {
    let rows: Vec<[f64; 4]> = colours.iter().map(|c| [1.0, c[0], c[1], c[2]]).collect();
    let gram: Vec<f64> = (0..16)
        .map(|ij| rows.iter().map(|x| x[ij / 4] * x[ij % 4]).sum())
        .collect();
    let rhs: Vec<f64> = (0..4)
        .map(|i| rows.iter().zip(colours).map(|(x, c)| x[i] * c[3]).sum())
        .collect();
    let fit = solve(gram, rhs).unwrap();
    let n = colours.len() as f64;
    let mean = colours.iter().map(|c| c[3]).sum::<f64>() / n;
    let total: f64 = colours.iter().map(|c| (c[3] - mean).powi(2)).sum();
    let residual: f64 = rows
        .iter()
        .zip(colours)
        .map(|(x, c)| (c[3] - dot(x, &fit)).powi(2))
        .sum();
    residual / total
}

#[test]
fn max_chroma_colours_spread_over_hues_and_carry_more_of_q_than_support_points() {
    let hs = pigeon();
    let colours_by = |rule| {
        let mut rng = StdRng::seed_from_u64(0);
        let library = hs.library_by(rule, 2000, &mut rng).unwrap();
        let distinct: std::collections::HashSet<Vec<u64>> = library
            .spectra
            .iter()
            .map(|r| r.iter().map(|v| v.to_bits()).collect())
            .collect();
        let colours: Vec<Vec<f64>> = library.spectra.iter().map(|r| hs.colour(r)).collect();
        (q_own_share(&colours), distinct.len())
    };
    let (support_share, support_distinct) = colours_by(HueRule::SupportPoint);
    let (max_share, max_distinct) = colours_by(HueRule::MaxChroma);
    eprintln!(
        "Q's own share: support point {:.3} % ({support_distinct} distinct), max chroma {:.3} % \
         ({max_distinct} distinct)",
        100.0 * support_share,
        100.0 * max_share
    );
    assert!(max_distinct > 1900, "{max_distinct} distinct of 2000");
    assert!(
        support_distinct < 500,
        "{support_distinct} distinct of 2000"
    );
    assert!(
        max_share > 3.0 * support_share,
        "{max_share} vs {support_share}"
    );
}

#[test]
fn a_grid_too_fine_for_the_max_basis_is_refused_by_name() {
    let g = WavelengthGrid::range(400.0, 700.0, 0.05).unwrap();
    let classes = lms_plus(ConeClass::pigeon_q());
    let f = sensitivities(&classes, &ConeTemplate::default(), &g).unwrap();
    let hs = HueSphere::new(&Projector::cones(&f), 4).unwrap();
    let e = MaxChromaHues::new(&hs).unwrap_err().to_string();
    assert!(e.contains("hue_rule") && e.contains("step_nm"), "{e}");
}
