//! Spatial colour statistics of photographs and of the synthetic generators, side by side
//! (`retina::scene::statistics`).
//!
//! Usage: `cargo run --release -p retina --example scene_statistics -- PHOTO_DIR OUT_DIR`
//! where PHOTO_DIR holds the 16-bit PNGs and `photos.json` of
//! `scripts/scene-statistics/prepare_photos.py`. Writes `OUT_DIR/photo_statistics.json` (the
//! photographs' statistics with their provenance: the file `retina/data/` keeps for the
//! generator test), `OUT_DIR/generators.json` (the classic dead leaves, the surfaces and the
//! hue-sphere tiles alone, 32 tiles each) and one SVG per statistic, and prints the curves and
//! the contrasts (the photographs' median and range beside each generator).
use colorimetry::plot::{LinePlot, Series};
use colorimetry::{ConeClass, ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::SeedableRng;
use retina::config::RetinaConfig;
use retina::scene::pool::{SceneGenerator, ScenePool, ScenePoolConfig, TetraMix};
use retina::scene::projection::SceneProjection;
use retina::scene::rgb::{class_planes_by_matrix, RgbImage};
use retina::scene::statistics::{
    distance_index, measure_image, SpatialStatistics, CROP_PX, DISTANCES_PX, NEIGHBOUR_CONES_PX,
};
use retina::scene::tetra::TetraEnvironment;
use serde_json::{json, Value};
use std::path::Path;

/// Tiles per generator.
const TILES: usize = 32;

/// The mean statistics of [`TILES`] tiles of `generator`, every tile from `tetra` if given.
fn generator_statistics(
    proj: &SceneProjection,
    generator: SceneGenerator,
    tetra: Option<TetraMix>,
) -> SpatialStatistics {
    let cfg = ScenePoolConfig {
        tiles: 1,
        tile_px: CROP_PX,
        generator,
        tetra,
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
            generator_statistics(&proj, SceneGenerator::DeadLeaves, None),
        ),
        (
            "surfaces",
            generator_statistics(&proj, SceneGenerator::Surfaces, None),
        ),
        (
            "hue-sphere tiles",
            generator_statistics(
                &proj,
                SceneGenerator::Surfaces,
                Some(TetraMix {
                    environment: TetraEnvironment::HueSphere,
                    fraction: 1.0,
                    hue_rule: Default::default(),
                }),
            ),
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
    print_contrasts(&measured, &gens);
}

/// One figure of a crop's statistics.
type Figure = dyn Fn(&SpatialStatistics) -> f64;

/// The contrasts' amplitudes: the photographs' median and range, then each generator.
fn print_contrasts(measured: &[Value], gens: &[(&str, SpatialStatistics)]) {
    let photos: Vec<SpatialStatistics> = measured
        .iter()
        .map(|e| serde_json::from_value(e["statistics"].clone()).unwrap())
        .collect();
    let spread = |f: &Figure| {
        let mut v: Vec<f64> = photos.iter().map(f).collect();
        v.sort_by(f64::total_cmp);
        format!("{:.4} ({:.4}–{:.4})", v[v.len() / 2], v[0], v[v.len() - 1])
    };
    let rows: [(&str, &Figure); 5] = [
        ("sd log luminance", &|s| s.contrast_sd[0]),
        ("sd red-green", &|s| s.contrast_sd[1]),
        ("sd blue-yellow", &|s| s.contrast_sd[2]),
        ("rms red-green difference at 2 px", &|s| {
            s.red_green_difference_rms[distance_index(NEIGHBOUR_CONES_PX)]
        }),
        ("rms red-green difference at 8 px", &|s| {
            s.red_green_difference_rms[distance_index(8)]
        }),
    ];
    for (name, f) in rows {
        let g: Vec<String> = gens
            .iter()
            .map(|(n, s)| format!("{n} {:.4}", f(s)))
            .collect();
        println!("== {name}: photographs {}; {}", spread(f), g.join("; "));
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
                .color(["#D55E00", "#000000", "#009E73"][i])
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
