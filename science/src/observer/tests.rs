use super::*;
use crate::config::RunConfig;
use colorimetry::observer::Stimulus;

fn tiny() -> (Retina, Cortex) {
    let config = RunConfig::preset("tiny", "LMS").unwrap();
    let retina = Retina::new(config.retina.clone()).unwrap();
    let cortex = Cortex::new(config.cortex.clone()).unwrap();
    (retina, cortex)
}

fn shows() -> Vec<Show> {
    let lines = [
        Stimulus::monochromatic(455.5, 0.8),
        Stimulus::Lines(vec![(530.0, 0.3), (612.7, 1.1)]),
        Stimulus::black(),
        Stimulus::Lines(vec![(401.0, 2.0), (560.0, 0.05), (699.0, 0.7)]),
    ];
    let locations = [[0.1, -0.2], [-0.35, 0.3], [0.1, -0.2], [0.0, 0.0]];
    lines
        .into_iter()
        .zip(locations)
        .map(|(stimulus, location)| Show {
            stimulus,
            location,
            noise_seed: 7,
        })
        .collect()
}

/// Builds a fresh observer.
type Maker = Box<dyn Fn() -> EyeObserver<'static>>;

/// Percepts of `shows`, one call per show on a fresh observer (cold cache, no batching).
fn one_by_one(make: &dyn Fn() -> EyeObserver<'static>, shows: &[Show]) -> Vec<f64> {
    let o = make();
    let dim = o.percept_dim();
    let mut all = vec![0.0; shows.len() * dim];
    for (s, show) in shows.iter().enumerate() {
        let fresh = make();
        fresh.percepts(std::slice::from_ref(show), &mut all[s * dim..(s + 1) * dim]);
    }
    all
}

fn assert_close(a: &[f64], b: &[f64], what: &str) {
    let scale = a.iter().fold(0f64, |m, v| m.max(v.abs())).max(1e-12);
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(
            (x - y).abs() <= 1e-5 * scale,
            "{what}: value {i}: {x} vs {y}"
        );
    }
}

#[test]
fn cached_percepts_equal_direct_renders_for_every_decoder() {
    let (retina, cortex) = tiny();
    let (retina, cortex): (&'static Retina, &'static Cortex) =
        (Box::leak(Box::new(retina)), Box::leak(Box::new(cortex)));
    let shows = shows();
    let oracle = || OracleDecoder::new(retina, true, 1).unwrap();
    let makers: Vec<(&str, Maker)> = vec![
        (
            "cortex",
            Box::new(|| EyeObserver::cortex(retina, cortex, ObserverSettings::default())),
        ),
        (
            "ons",
            Box::new(|| EyeObserver::new(retina, Decoder::Ons, ObserverSettings::default())),
        ),
        (
            "cones",
            Box::new(|| EyeObserver::new(retina, Decoder::Cones, ObserverSettings::default())),
        ),
        (
            "oracle",
            Box::new(move || {
                EyeObserver::new(
                    retina,
                    Decoder::Oracle(oracle()),
                    ObserverSettings::default(),
                )
            }),
        ),
    ];
    for (name, make) in &makers {
        let o = make();
        let dim = o.percept_dim();
        let mut batched = vec![0.0; shows.len() * dim];
        o.percepts(&shows, &mut batched);
        assert_close(&batched, &one_by_one(make.as_ref(), &shows), name);
        // The cached linear combination equals the direct render through the decoder.
        let direct: Vec<f64> = shows
            .iter()
            .flat_map(|show| {
                let (act, ons) = o.render(show);
                let cells = o
                    .readout
                    .cells(&retina.layout, o.disc(show.location).centre_px);
                let d = o.decoder.dim();
                let planes = match &o.decoder {
                    Decoder::Cortex(c) => c.decode_frames(&ons, 1),
                    _ => o.linear_percept(&act, &ons, false),
                };
                let mut r = vec![0.0; o.readout.len(d)];
                o.readout.read(&planes, d, &cells, &mut r);
                r
            })
            .collect();
        assert_close(&batched, &direct, name);
    }
}

/// Moves every parameter of `cortex` off its initialisation by up to ±0.1 (an LCG from `seed`),
/// so that no layer is the identity or zero.
fn move_off_initialisation(cortex: &mut Cortex, seed: u32) {
    let ids: Vec<_> = cortex.params.ids().collect();
    let mut k = seed;
    for id in ids {
        for v in cortex.params.get_mut(id).data_mut() {
            k = k.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            *v += ((k >> 8) as f32 / (1u32 << 24) as f32 - 0.5) * 0.2;
        }
    }
}

#[test]
fn windowed_cortex_percepts_equal_whole_field_ones() {
    // The quick eye (64 × 64 cones) with a small patch and a one-level U-Net, so that a patch's
    // window is a fraction of the field; every parameter moved off its initialisation.
    let config = RunConfig::preset("quick", "LMS").unwrap();
    let retina: &'static Retina = Box::leak(Box::new(Retina::new(config.retina.clone()).unwrap()));
    let mut cc = config.cortex.clone();
    cc.d.widths = vec![8, 16];
    let mut cortex = Cortex::new(cc).unwrap();
    move_off_initialisation(&mut cortex, 5);
    let cortex: &'static Cortex = Box::leak(Box::new(cortex));
    let settings = ObserverSettings {
        patch_radius_fraction: 1.0 / 16.0,
        ..ObserverSettings::default()
    };
    let windowed = EyeObserver::cortex(retina, cortex, settings.clone());
    let whole = EyeObserver::cortex(retina, cortex, settings).decoding_whole_field();
    let shows = shows();
    let n = retina.n();
    for show in &shows {
        let cells = windowed
            .readout
            .cells(&retina.layout, windowed.disc(show.location).centre_px);
        let rows = cells.iter().map(|&i| i / n);
        let cols = cells.iter().map(|&i| i % n);
        let w = cortex.exact_window(
            [rows.clone().min().unwrap(), rows.max().unwrap()],
            [cols.clone().min().unwrap(), cols.max().unwrap()],
        );
        assert!(
            w.height * w.width * 2 < n * n,
            "window {w:?} of a {n} × {n} field"
        );
    }
    let dim = windowed.percept_dim();
    let (mut a, mut b) = (vec![0.0; shows.len() * dim], vec![0.0; shows.len() * dim]);
    windowed.percepts(&shows, &mut a);
    whole.percepts(&shows, &mut b);
    assert!(b.iter().any(|&v| v != 0.0), "the percepts are all zero");
    assert_close(&a, &b, "windowed vs whole field");
}

#[test]
fn a_cortex_percept_does_not_depend_on_the_shows_decoded_with_it() {
    // CMF-SIM's passes may group shows differently (rounds, converging copies): each show's
    // percept must be the same to the last bit whether decoded alone or in a batch.
    let config = RunConfig::preset("quick", "LMS").unwrap();
    let retina: &'static Retina = Box::leak(Box::new(Retina::new(config.retina.clone()).unwrap()));
    let mut cortex = Cortex::new(config.cortex.clone()).unwrap();
    move_off_initialisation(&mut cortex, 11);
    let cortex: &'static Cortex = Box::leak(Box::new(cortex));
    let settings = ObserverSettings::default();
    let make = move || EyeObserver::cortex(retina, cortex, settings.clone());
    // 20 shows: a batch of `decode_batch` (16) and smaller ones, against one show at a time.
    let shows: Vec<Show> = (0..5)
        .flat_map(|r| {
            shows().into_iter().map(move |mut s| {
                s.location = [s.location[0] + 0.05 * r as f64, s.location[1]];
                s
            })
        })
        .collect();
    let dim = make().percept_dim();
    let mut batched = vec![0.0; shows.len() * dim];
    make().percepts(&shows, &mut batched);
    let alone = one_by_one(&make, &shows);
    assert!(
        batched.iter().any(|&v| v != 0.0),
        "the percepts are all zero"
    );
    let differ = batched.iter().zip(&alone).filter(|(a, b)| a != b).count();
    assert_eq!(differ, 0, "{differ} of {} values differ", batched.len());
}
