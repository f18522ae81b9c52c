//! Numeric settings out of their range, and values that once crashed, hung or exhausted the
//! machine: each a one-line error naming the file (or `--set`/flag) and the field, before any
//! folder is made. The same shape as [`super::cases`].

use super::cases::{case, Case};

pub const RANGE_CASES: &[Case] = &[
    case(
        "grid step 0.0001 nm",
        Some("[retina.grid]\nstep_nm = 0.0001"),
        &[],
        &["bad.toml", "retina.grid.step_nm"],
    ),
    case(
        "grid step 1e30 nm",
        Some("[retina.grid]\nstep_nm = 1e30"),
        &[],
        &["bad.toml", "retina.grid.step_nm"],
    ),
    case(
        "grid to 900 nm, inside its range but past the eye's tables",
        None,
        &["--set", "retina.grid.end_nm=900"],
        &["retina.grid.end_nm", "390–830 nm"],
    ),
    case(
        "grid from 300 nm, past the eye's tables",
        Some("[retina.grid]\nstart_nm = 300"),
        &[],
        &["bad.toml", "retina.grid.start_nm", "390–830 nm"],
    ),
    case(
        "location pairs 100 000",
        Some("[cmf_sim]\nlocation_pairs = 100000"),
        &[],
        &["bad.toml", "cmf_sim.location_pairs"],
    ),
    case(
        "set tiles 1e9",
        None,
        &["--set", "retina.scenes.tiles=1000000000"],
        &["--set retina.scenes.tiles"],
    ),
    case(
        "set tile_px 1e9",
        None,
        &["--set", "retina.scenes.tile_px=1000000000"],
        &["--set retina.scenes.tile_px"],
    ),
    case(
        "set test wavelengths 1e9",
        None,
        &["--set", "cmf_sim.n_test_wavelengths=1000000000"],
        &["--set cmf_sim.n_test_wavelengths"],
    ),
    case(
        "set location pairs 1e9",
        None,
        &["--set", "cmf_sim.location_pairs=1000000000"],
        &["--set cmf_sim.location_pairs"],
    ),
    case(
        "max aspect 1e30",
        Some("[retina.scenes.dead_leaves]\nmax_aspect = 1e+30"),
        &[],
        &["bad.toml", "retina.scenes.dead_leaves.max_aspect"],
    ),
    case(
        "eval batches 1e9",
        Some("[schedule]\neval_batches = 1000000000"),
        &[],
        &["bad.toml", "schedule.eval_batches"],
    ),
    case(
        "photon noise nan",
        Some("[retina.noise]\nphoton_noise_scale = nan"),
        &[],
        &["bad.toml", "retina.noise.photon_noise_scale"],
    ),
    case(
        "photon noise 1e30",
        Some("[retina.noise]\nphoton_noise_scale = 1e30"),
        &[],
        &["bad.toml", "retina.noise.photon_noise_scale"],
    ),
    case(
        "li noise 1e30",
        Some("[retina.noise]\nli_noise_scale = 1e30"),
        &[],
        &["bad.toml", "retina.noise.li_noise_scale"],
    ),
    case(
        "peak density 0",
        Some("[retina.layout.Foveated.density]\npeak_density_per_deg2 = 0.0"),
        &[],
        &["bad.toml", "peak_density_per_deg2"],
    ),
    case(
        "jitter amplitude 1e9",
        Some("[retina.layout.Foveated.jitter]\namplitude_cells = 1e9"),
        &[],
        &["bad.toml", "amplitude_cells"],
    ),
    case(
        "optical density nan",
        Some("[retina.template]\noptical_density = nan"),
        &[],
        &["bad.toml", "retina.template.optical_density"],
    ),
    case(
        "primary separation 1000 nm",
        Some("[cmf_sim]\nmin_primary_separation_nm = 1000.0"),
        &[],
        &["bad.toml", "cmf_sim.min_primary_separation_nm"],
    ),
    case(
        "primary separation wider than a band",
        Some("[cmf_sim]\nmin_primary_separation_nm = 200.0"),
        &[],
        &["bad.toml", "cmf_sim.min_primary_separation_nm", "bands"],
    ),
    case(
        "learning rate 1e30",
        Some("[cortex.train]\nlearning_rate = 1e30"),
        &[],
        &["bad.toml", "cortex.train.learning_rate"],
    ),
    case(
        "set adam eps 0",
        None,
        &["--set", "cortex.train.adam_eps=0"],
        &["--set cortex.train.adam_eps", "positive"],
    ),
];
