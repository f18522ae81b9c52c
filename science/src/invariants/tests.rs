//! Known answers: a perfectly learned bucket scores as recovered, a random or untrained one
//! does not, on the real `tiny` eye's classes and positions.

use super::*;
use crate::config::RunConfig;
use cortex::rng::CortexRng;

fn tiny_eye() -> (RunConfig, Retina) {
    let config = RunConfig::preset("tiny", "LMS").unwrap();
    let retina = Retina::new(config.retina.clone()).unwrap();
    (config, retina)
}

#[test]
fn c_from_class_prototypes_is_recovered_and_random_c_is_not() {
    let (_, retina) = tiny_eye();
    let truth = retina.mosaic.dominant_class();
    let names = retina.mosaic.class_names();
    let dim = 8;
    let mut rng = CortexRng::seed_from(3);
    let prototypes: Vec<Vec<f64>> = (0..names.len())
        .map(|_| (0..dim).map(|_| rng.normal()).collect())
        .collect();
    let perfect: Vec<f64> = truth
        .iter()
        .flat_map(|&t| prototypes[t].clone())
        .map(|v| v + 0.05 * rng.normal())
        .collect();
    let good = measure_c(&perfect, dim, &truth, &names);
    assert!(good.adjusted_rand_index > 0.99, "{good:?}");
    for r in good
        .recall_kmeans
        .iter()
        .chain(&good.recall_nearest_centroid)
    {
        assert!(*r > 0.99, "{good:?}");
    }
    assert!(good.dprime.iter().all(|&d| d > 10.0), "{good:?}");

    let random: Vec<f64> = (0..truth.len() * dim).map(|_| rng.normal()).collect();
    let bad = measure_c(&random, dim, &truth, &names);
    assert!(bad.adjusted_rand_index.abs() < 0.05, "{bad:?}");
    assert!(bad.dprime.iter().all(|&d| d < 0.5), "{bad:?}");
    let worst = bad.recall_kmeans.iter().cloned().fold(1.0, f64::min);
    assert!(worst < 0.7, "{bad:?}");
}

#[test]
fn w_equal_to_the_dog_is_recovered_and_the_identity_is_not() {
    let (_, retina) = tiny_eye();
    let (dog, size) = retina.dog_kernel().unwrap();
    assert_eq!(size, 7);
    let dc: f64 = dog.iter().sum();
    let same = measure_w(dog, dc, dog);
    assert!((same.kernel_r - 1.0).abs() < 1e-12 && (same.surround_r - 1.0).abs() < 1e-12);
    assert!((same.dc_factor() - 1.0).abs() < 1e-12);
    let mut identity = vec![0.0; 49];
    identity[24] = 1.0;
    let init = measure_w(&identity, 1.0, dog);
    assert_eq!(init.surround_r, 0.0);
    assert!(init.dc_factor() > 2.0, "{init:?}");
}

#[test]
fn positions_equal_up_to_an_affine_map_are_recovered_and_jittered_ones_are_not() {
    let (_, retina) = tiny_eye();
    let n = retina.n();
    let truth = true_positions(&retina);
    let affine: Vec<[f64; 2]> = truth
        .iter()
        .map(|p| {
            [
                0.7 * p[0] + 0.2 * p[1] - 0.1,
                -0.1 * p[0] + 1.2 * p[1] + 0.3,
            ]
        })
        .collect();
    let good = measure_p(&affine, &truth, n);
    assert!(good.position_error_rms_cones < 1e-9, "{good:?}");
    assert!((good.spacing_r - 1.0).abs() < 0.05, "{good:?}");
    // Jitter of σ = 0.5 local spacing per axis: RMS error ≈ 0.5·√2 ≈ 0.71 spacings.
    let spacing = super::positions::local_spacing(&truth, n);
    let mut rng = CortexRng::seed_from(5);
    let jittered: Vec<[f64; 2]> = truth
        .iter()
        .zip(&spacing)
        .map(|(p, s)| [p[0] + 0.5 * s * rng.normal(), p[1] + 0.5 * s * rng.normal()])
        .collect();
    let bad = measure_p(&jittered, &truth, n);
    assert!(
        (bad.position_error_rms_cones - 0.71).abs() < 0.08,
        "{bad:?}"
    );
}

#[test]
fn an_untrained_cortex_has_recovered_nothing() {
    let (config, retina) = tiny_eye();
    let cortex = Cortex::new(config.cortex.clone()).unwrap();
    let r = measure(&cortex, &retina);
    let c = r.c.as_ref().unwrap();
    assert!(c.adjusted_rand_index < 0.1, "{c:?}");
    let w = r.w.as_ref().unwrap();
    assert_eq!(w.surround_r, 0.0);
    assert!(
        (w.dc_gain - 1.0).abs() < 1e-6 && w.dc_factor() > 2.0,
        "{w:?}"
    );
    // The initial P is the uniform lattice; the foveated truth is not affine to it.
    assert!(r.p.position_error_rms_cones > 0.5, "{:?}", r.p);
    assert_eq!(r.describe().len(), 3);
    eprintln!("{:#?}", r.describe());
}

#[test]
fn one_class_has_no_dprime_and_its_record_reads_back() {
    let c: Vec<f64> = (0..20).map(|i| (i as f64).sin()).collect();
    let r = measure_c(&c, 2, &[0; 10], &["L".to_string()]);
    assert!(r.dprime[0].is_nan(), "{:?}", r.dprime);
    let text = serde_json::to_string(&r).unwrap();
    assert!(text.contains("\"dprime\":[null]"), "{text}");
    let back: CRecovery = serde_json::from_str(&text).unwrap();
    assert!(back.dprime[0].is_nan() && back.recall_nearest_centroid == r.recall_nearest_centroid);
    // A class no cone belongs to has no recall; its record reads back too.
    let empty = measure_c(&c, 2, &[0; 10], &["L".to_string(), "M".to_string()]);
    assert!(empty.recall_nearest_centroid[1].is_nan(), "{empty:?}");
    let text = serde_json::to_string(&empty).unwrap();
    let back: CRecovery = serde_json::from_str(&text).unwrap();
    assert!(back.recall_kmeans[1].is_nan() && back.recall_nearest_centroid[1].is_nan());
    let said = Recovery {
        c: Some(r),
        w: None,
        p: PRecovery {
            spacing_r: 0.9,
            position_error_rms_cones: 0.3,
            position_error_median_cones: 0.2,
        },
        hidden: None,
        directions: None,
    }
    .describe();
    assert!(
        said[0].contains("d′ —;") && !said[0].contains("NaN"),
        "{said:?}"
    );
}

/// The held-out scenes are drawn and read one batch at a time: gathered to the end, every scene
/// is a sample and the last is kept whole; a `go_on` that refuses before the third batch ends
/// the gathering with its error, two batches drawn and decoded, no more.
#[test]
fn gathering_reads_batch_by_batch_and_stops_where_go_on_refuses() {
    let config = RunConfig::preset("tiny", "LMS").unwrap();
    let dim = 2;
    let gather = |refuse_at: usize| {
        let mut source = crate::heldout::hidden_source(&config).unwrap();
        let n = source.retina.n();
        let (mut decoded, mut asked) = (0, 0);
        let decode = |_: &[f32], count: usize| {
            decoded += count;
            vec![0.5; count * dim * n * n]
        };
        let go_on = || {
            asked += 1;
            match asked > refuse_at {
                true => Err("refused"),
                false => Ok(()),
            }
        };
        let out = gather_held_out(&mut source, 40, dim, 0, decode, go_on);
        (out, source.batches_drawn(), decoded, n)
    };
    let (whole, drawn, decoded, n) = gather(usize::MAX);
    let whole = whole.unwrap();
    assert_eq!((drawn, decoded), (10, 40));
    assert_eq!(whole.samples.len(), 40);
    let last = whole.last.expect("the last scene is kept");
    assert_eq!(
        (last.percept.len(), last.excitation.len(), last.srgb.len()),
        (dim * n * n, 3 * n * n, 3 * n * n)
    );
    let (stopped, drawn, decoded, _) = gather(2);
    assert_eq!(stopped.err(), Some("refused"));
    assert_eq!((drawn, decoded), (2, 2 * HIDDEN_BATCH_SIZE));
}
