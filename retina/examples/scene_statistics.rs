//! Spatial colour statistics of photographs and of the synthetic generators, side by side
//! (`retina::scene::statistics`).
//!
//! Usage: `cargo run --release -p retina --example scene_statistics -- PHOTO_DIR OUT_DIR`
//! where PHOTO_DIR holds the 16-bit PNGs and `photos.json` of
//! `scripts/scene-statistics/prepare_photos.py`. Writes `OUT_DIR/photo_statistics.json` (the
//! photographs' statistics with their provenance: the file `retina/data/` keeps for the
//! generator test), `OUT_DIR/generators.json` (the classic dead leaves and the surfaces, 32
//! tiles each) and one SVG per statistic, and prints the curves.
use colorimetry::plot::{LinePlot, Series};
use colorimetry::{ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::SeedableRng;
use retina::config::RetinaConfig;
use retina::scene::pool::{SceneGenerator, ScenePool, ScenePoolConfig};
use retina::scene::projection::SceneProjection;
use retina::scene::rgb::{class_planes_by_matrix, RgbImage};
use retina::scene::statistics::{measure_image, SpatialStatistics, CROP_PX, DISTANCES_PX};
use serde_json::{json, Value};
use std::path::Path;

/// Tiles per generator.
const TILES: usize = 32;

fn generator_statistics(proj: &SceneProjection, generator: SceneGenerator) -> SpatialStatistics {
    let cfg = ScenePoolConfig {
        tiles: 1,
        tile_px: CROP_PX,
        generator,
        tetra: None,
        refresh_every_batches: 0,
        ..RetinaConfig::quick().scenes
    };
    let pool = ScenePool::new(cfg, proj.clone(), 1, &mut StdRng::seed_from_u64(7)).unwrap();
    let mut rng = StdRng::seed_from_u64(11);
    let all: Vec<SpatialStatistics> = (0..TILES)
        .map(|i| {
            let p = pool.make_planes(i, &mut rng).unwrap();
            measure_image(&p.planes, p.h, p.w).unwrap()
        })
        .collect();
    SpatialStatistics::mean(&all)
}

fn main() {
    let a: Vec<String> = std::env::args().collect();
    let (photos, out) = (Path::new(&a[1]), Path::new(&a[2]));
    std::fs::create_dir_all(out).unwrap();
    let grid = WavelengthGrid::default();
    let proj = SceneProjection::new(&ConeClass::lms(), &ConeTemplate::default(), &grid).unwrap();
    let manifest: Vec<Value> =
        serde_json::from_str(&std::fs::read_to_string(photos.join("photos.json")).unwrap())
            .unwrap();
    let mut measured = Vec::new();
    for entry in &manifest {
        let file = entry["file"].as_str().unwrap();
        let rgb = RgbImage::read_png(photos.join(file)).unwrap();
        let planes = class_planes_by_matrix(&rgb, &proj.cone_rgb);
        let s = measure_image(&planes, rgb.h, rgb.w).unwrap();
        let mut e = entry.clone();
        e["statistics"] = serde_json::to_value(&s).unwrap();
        measured.push(e);
    }
    let doc = json!({
        "scale": "linear sRGB resized in linear light to a 542-px short side (2 px per cone), the official sRGB-to-cone matrix",
        "crop_px": CROP_PX,
        "distances_px": DISTANCES_PX,
        "photos": measured,
    });
    std::fs::write(
        out.join("photo_statistics.json"),
        serde_json::to_string_pretty(&doc).unwrap(),
    )
    .unwrap();
    let gens = [
        (
            "dead leaves (classic)",
            generator_statistics(&proj, SceneGenerator::DeadLeaves),
        ),
        (
            "surfaces",
            generator_statistics(&proj, SceneGenerator::Surfaces),
        ),
    ];
    let gdoc: Value = gens
        .iter()
        .map(|(n, s)| (n.to_string(), serde_json::to_value(s).unwrap()))
        .collect::<serde_json::Map<_, _>>()
        .into();
    std::fs::write(
        out.join("generators.json"),
        serde_json::to_string_pretty(&gdoc).unwrap(),
    )
    .unwrap();
    plot_curves(out, &measured, &gens);
    for (g, s) in &gens {
        println!(
            "{g:>24}: spectral slopes (luminance, red-green, blue-yellow) {:.2?}",
            s.spectral_slopes
        );
    }
}

/// One plot per statistic: every photograph (grey fitted, blue held out) and each generator,
/// with the generators' curves printed.
fn plot_curves(out: &Path, measured: &[Value], gens: &[(&str, SpatialStatistics)]) {
    let xs: Vec<f64> = DISTANCES_PX.iter().map(|&d| d as f64).collect();
    for (c, (name, _)) in gens[0].1.curves().iter().enumerate() {
        let mut plot = LinePlot::new(
            format!("{name}: photographs (grey: fitted, blue: held out) and generators"),
            "distance between the two points, px (2 px per cone)",
            if c == 3 {
                "share of pairs of the same colour"
            } else {
                "autocorrelation"
            },
        );
        plot.y_min = Some(0.0);
        plot.y_max = Some(1.0);
        for e in measured {
            let s: SpatialStatistics = serde_json::from_value(e["statistics"].clone()).unwrap();
            let held = e["held_out"].as_bool().unwrap();
            let label = format!(
                "{}{}",
                e["file"].as_str().unwrap(),
                if held { " (held out)" } else { "" }
            );
            plot.push(
                Series::new(label, xs.clone(), s.curves()[c].1.to_vec()).color(if held {
                    "#56B4E9"
                } else {
                    "#BBBBBB"
                }),
            );
        }
        for (i, (g, s)) in gens.iter().enumerate() {
            let series = Series::new(*g, xs.clone(), s.curves()[c].1.to_vec())
                .color(["#D55E00", "#000000"][i])
                .markers();
            plot.push(if i == 0 { series.dashed() } else { series });
        }
        let file = name.replace([' ', '-'], "_");
        plot.save(out.join(format!("{file}.svg"))).unwrap();
        println!("== {name} at d = {DISTANCES_PX:?}");
        for (g, s) in gens {
            println!(
                "{g:>24}: {}",
                s.curves()[c]
                    .1
                    .iter()
                    .map(|v| format!("{v:.2}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            );
        }
    }
}
