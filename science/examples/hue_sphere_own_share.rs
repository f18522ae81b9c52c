//! Q's own share over an observer's hue-sphere colours themselves — no scenes, no shading, no
//! eye: the colours `retina::scene::hue_sphere` gives the hue-sphere environment (one optimal
//! reflectance per uniformly drawn hue, its class excitations under the reference daylight,
//! white-normalised: the perfect white is 1 in every class), and the share of Q's variance over
//! them that an affine least-squares fit of Q from L, M, S does not predict
//! (`science::fourth::own_signal`).
//!
//! `cargo run --release -p science --example hue_sphere_own_share -- [CONES] [COUNT] [SEED]
//! [STEP_NM] [LIGHT] [OUT_DIR] [--rule=RULE]`, defaults `LMSQ,Q:506` (pigeon Q; `LMSQ` is human Q), 3481
//! colours, seed 0, the eye's 10 nm grid (400–700 nm), `D6504` (the hue sphere's own reference
//! daylight; `E` is equal energy, for A/B checks: the projector is divided by that daylight
//! before `HueSphere::new` multiplies it back), no files, and the hue rule `support_point`
//! (`--rule=max_chroma`: `retina::scene::hue_sphere::HueRule`). Prints, in % of Q's variance over the colours:
//! the in-sample share (one fit on every colour, as over a fixed set) and the held-out share
//! (fit on the first half, scored on the second: `own_share`'s "across" with the halves as its
//! two tiles); then the fit `[c₀, c_L, c_M, c_S]`, Q's variance (white-normalised units²) and
//! the number of distinct reflectances. With OUT_DIR it writes `colours.csv` (L, M, S, Q per
//! colour) and `weights.csv` (wavelength, then each class's white-normalised weight
//! `F̃_c(λ)`, whose sum over λ is 1) for offline checks.

use colorimetry::{ConeTemplate, WavelengthGrid};
use rand::rngs::StdRng;
use rand::SeedableRng;
use retina::scene::hue_sphere::{HueRule, HueSphere, HUE_SPHERE_DAYLIGHT_CCT_K};
use retina::scene::library::daylight_unit_luminance;
use retina::scene::projection::SceneProjection;
use retina::MosaicSpec;
use science::fourth::own_signal::{own_share, q_from_lms};
use std::collections::HashSet;
use std::fmt::Write as _;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let all: Vec<String> = std::env::args().skip(1).collect();
    let rule = match all.iter().find(|a| a.starts_with("--rule=")) {
        Some(r) => toml::Value::String(r["--rule=".len()..].into()).try_into::<HueRule>()?,
        None => HueRule::SupportPoint,
    };
    let a: Vec<String> = all
        .into_iter()
        .filter(|a| !a.starts_with("--rule="))
        .collect();
    let arg = |i: usize, default: &str| a.get(i).cloned().unwrap_or_else(|| default.into());
    let (cones, count, seed) = (arg(0, "LMSQ,Q:506"), arg(1, "3481").parse()?, arg(2, "0"));
    let step: f64 = arg(3, "10").parse()?;
    let spec = MosaicSpec::parse(&cones)?;
    let classes = spec
        .class_names()
        .iter()
        .map(|n| spec.class(n))
        .collect::<Result<Vec<_>, _>>()?;
    if classes.len() != 4 {
        return Err(format!("CONES `{cones}`: needs L, M, S and a fourth class").into());
    }
    let grid = WavelengthGrid::range(400.0, 700.0, step)?;
    let mut projector = SceneProjection::new(&classes, &ConeTemplate::default(), &grid)?.projector;
    let light = arg(4, "D6504");
    if light == "E" {
        let daylight = daylight_unit_luminance(HUE_SPHERE_DAYLIGHT_CCT_K, &grid)?;
        for (i, m) in projector.matrix.iter_mut().enumerate() {
            *m = (*m as f64 / daylight[i % grid.len()]) as f32;
        }
    } else if light != "D6504" {
        return Err(format!("LIGHT `{light}`: D6504 or E").into());
    }
    let sphere = HueSphere::new(&projector, 4)?;
    let mut rng = StdRng::seed_from_u64(seed.parse()?);
    let reflectances = sphere.library_by(rule, count, &mut rng)?.spectra;
    let colours: Vec<[f64; 4]> = reflectances
        .iter()
        .map(|r| {
            let c = sphere.colour(r);
            [c[0], c[1], c[2], c[3]]
        })
        .collect();
    let distinct: HashSet<Vec<bool>> = reflectances
        .iter()
        .map(|r| r.iter().map(|&v| v > 0.5).collect())
        .collect();

    let c = q_from_lms(&colours);
    let residual = |x: &[f64; 4]| x[3] - c[0] - c[1] * x[0] - c[2] * x[1] - c[3] * x[2];
    let n = colours.len() as f64;
    let mean_q = colours.iter().map(|x| x[3]).sum::<f64>() / n;
    let q_var = colours.iter().map(|x| (x[3] - mean_q).powi(2)).sum::<f64>() / n;
    let res_var = colours.iter().map(|x| residual(x).powi(2)).sum::<f64>() / n;
    let half = colours.len() / 2;
    let held_out = own_share(&[colours[..half].to_vec(), colours[half..].to_vec()]).across;
    println!(
        "{cones}: {count} colours (seed {seed}, {step} nm grid, {light}), {} distinct reflectances",
        distinct.len()
    );
    println!(
        "Q own share: in-sample {:.3} %, held-out {:.3} %",
        100.0 * res_var / q_var,
        100.0 * held_out
    );
    println!("fit [c0, cL, cM, cS] = {c:.4?}; Q variance {q_var:.5e}, residual {res_var:.5e}");

    if let Some(dir) = a.get(5) {
        let dir = std::path::Path::new(dir);
        std::fs::create_dir_all(dir)?;
        let mut s = String::from("L,M,S,Q\n");
        for x in &colours {
            writeln!(s, "{},{},{},{}", x[0], x[1], x[2], x[3])?;
        }
        std::fs::write(dir.join("colours.csv"), s)?;
        // The unit reflectance at one wavelength has colour F̃(λ).
        let mut s = String::from("nm,L,M,S,Q\n");
        for (l, nm) in grid.wavelengths_nm().iter().enumerate() {
            let mut unit = vec![0.0; grid.len()];
            unit[l] = 1.0;
            let w = sphere.colour(&unit);
            writeln!(s, "{nm},{},{},{},{}", w[0], w[1], w[2], w[3])?;
        }
        std::fs::write(dir.join("weights.csv"), s)?;
    }
    Ok(())
}
