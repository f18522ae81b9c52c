//! Retina speed (criterion; `cargo bench --bench retina`).
//!
//! `retina_batch8/<preset>`: one call of `Retina::batch_into` producing 8 ONS pairs
//! `(8, 2, n, n)` — tile choice, eye shift, mip-mapped cone sampling, photon noise, 7×7 lateral
//! inhibition and LI noise for both frames, samples in parallel — with the preset's pool refresh
//! (one tile regenerated every `refresh_every_batches` calls) included, as in training.
//!
//! Target: ≤ 10 % of one training step at the same scale, so the eye never limits
//! learning — the quick step target is ~61 ms, so ≤ 6 ms here; paper scale proportionally.
//! Pool construction (scene generation) happens once, outside the timing.
//!
//! `held_out_stream/{draw,skip}`: the hidden measures' held-out stream of the quick eye
//! (`science::heldout::hidden_source`, a new tile every batch) drawing one batch of its
//! `HIDDEN_BATCH_SIZE` scenes against passing over it (`RetinaSource::skip_batches`: the tile
//! refresh alone), as `own_image` and a resumed run pass over the scenes before theirs. The new
//! tile (its Perlin textures) is most of both.
//!
//! `perlin/texture_192`: one texture field of a quick-eye surface tile (5 octaves, 192²).

use criterion::{criterion_group, criterion_main, Criterion};
use rand::rngs::SmallRng;
use rand::SeedableRng;
use retina::{EyeBatch, Retina, RetinaConfig};
use std::hint::black_box;
use std::time::Duration;

fn batch8(c: &mut Criterion) {
    let mut group = c.benchmark_group("retina_batch8");
    for preset in ["sandbox", "quick", "paper"] {
        let mut retina =
            Retina::new(RetinaConfig::preset(preset).expect("preset")).expect("retina");
        let mut rng = SmallRng::seed_from_u64(0);
        let mut out = EyeBatch::default();
        if preset == "paper" {
            group
                .sample_size(20)
                .measurement_time(Duration::from_secs(10));
        } else {
            group
                .sample_size(100)
                .measurement_time(Duration::from_secs(5));
        }
        group.bench_function(preset, |b| {
            b.iter(|| {
                retina.batch_into(&mut rng, 8, &mut out.signal, &mut out.truth);
                black_box(&out.signal.ons);
            })
        });
    }
    group.finish();
}

fn held_out_stream(c: &mut Criterion) {
    let mut group = c.benchmark_group("held_out_stream");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(10));
    let config = science::config::RunConfig::preset("quick", "LMS").expect("preset");
    let batch = science::invariants::HIDDEN_BATCH_SIZE;
    let mut drawn = science::heldout::hidden_source(&config).expect("stream");
    group.bench_function("draw", |b| {
        b.iter(|| black_box(&drawn.next_eye_batch(batch).signal.ons).len())
    });
    let mut skipped = science::heldout::hidden_source(&config).expect("stream");
    group.bench_function("skip", |b| {
        b.iter(|| {
            skipped.skip_batches(1);
            black_box(skipped.batches_drawn())
        })
    });
    group.finish();
}

/// The surface scenes' texture field of a quick-eye tile: 5 octaves of Perlin noise on 192 ×
/// 192 pixels from 3 periods (`SurfacesConfig`'s 64 px coarsest period); a tile draws several.
fn perlin(c: &mut Criterion) {
    let mut group = c.benchmark_group("perlin");
    group
        .sample_size(50)
        .measurement_time(Duration::from_secs(5));
    let mut rng = SmallRng::seed_from_u64(0);
    group.bench_function("texture_192", |b| {
        b.iter(|| {
            black_box(retina::foveation::perlin::perlin_octaves(
                &mut rng, 192, 192, 3, 5, 0.6,
            ))
        })
    });
    group.finish();
}

criterion_group!(benches, batch8, held_out_stream, perlin);
criterion_main!(benches);
