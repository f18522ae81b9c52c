//! The black-box colour observer CMF-SIM probes: the simulated retina followed by the learned
//! cortical decoder Φ (paper S-04: "the retina model plus learned cortical model as a black-box
//! color observer").
//!
//! One show (a spectral stimulus at a location) is rendered as follows (official-implementation.md
//! §4.2, proposed defaults, adapted to small lattices):
//! - **Stimulus.** A disc of radius `patch_radius_fraction × field side` on a black background,
//!   centred at the show's location (`[-1, 1]²` over the field, x to the right, y down). Its
//!   spectrum is projected once onto the retina's class planes (it is linear), the disc edge is
//!   anti-aliased over one pixel.
//! - **Eye.** One frame, no eye motion, [`Retina::encode_frame`] (cone sampling at the true
//!   positions, lateral inhibition). Noise-free by default (`noise_ratio = 0`); with a positive
//!   ratio the training noise model is applied with a seed derived from the show's `noise_seed`.
//! - **Cortex.** [`Cortex::decode_frames`]: the percept `(N, n, n)` in ONS coordinates.
//! - **Readout.** The mean percept over the cones whose *true* position lies inside the disc
//!   shrunk by `fringe_cones` cone spacings (avoids the lateral-inhibition fringe). Evaluation may
//!   use ground truth; learning never does.
//!
//! **Speed.** Without noise the eye is linear up to the ONS (disc render, mip stack, cone
//! sampling and lateral inhibition are all linear), so the ONS of a stimulus at a location is
//! `Σ_c v_c · B_c`, where `v` are the stimulus's class-plane values and `B_c` the ONS of a unit
//! disc on plane c there. The `B_c` and the readout cones of each location are computed once and
//! cached (CMF-SIM shows every location many times); [`LearnedObserver::render_ons`] is the
//! direct path, used with noise and as the reference in tests. Decoding runs in rayon jobs of at
//! most `decode_batch` shows, split evenly over the threads.

use autodiff::Tape;
use colorimetry::observer::{Observer, Show};
use colorimetry::WavelengthGrid;
use cortex::model::Marks;
use cortex::Cortex;
use rand::RngCore;
use rand::SeedableRng;
use rayon::prelude::*;
use retina::foveation::MipStack;
use retina::Retina;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Largest total size of the per-location cache, bytes (beyond it, shows render directly).
const CACHE_LIMIT_BYTES: usize = 1 << 30;

/// Entries by location (bit patterns of x, y) and the bytes they hold.
#[derive(Default)]
struct LocationCache {
    entries: HashMap<[u64; 2], Arc<LocationEntry>>,
    bytes: usize,
}

/// What the observer keeps per patch location.
struct LocationEntry {
    /// ONS of a unit disc on each cone-read plane, `(k × n·n)`.
    basis: Vec<f32>,
    /// Readout cones.
    inside: Vec<usize>,
}

/// Settings of the learned observer (see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ObserverSettings {
    /// Patch radius as a fraction of the field side (official proposal: 16 px of 512 = 1/32 at
    /// 256 cones; small lattices need relatively larger patches to cover enough cones).
    pub patch_radius_fraction: f64,
    /// Cone spacings removed from the patch edge before averaging (official §4.2: 3 px).
    pub fringe_cones: f64,
    /// Largest single-class response to a monochromatic test light (official §4.2: 0.5–0.8;
    /// training white ≈ 1 after white balance).
    pub peak_response: f64,
    /// Photon/LI noise ratio r of the renders (0: noise-free).
    pub noise_ratio: f32,
    /// Largest number of shows decoded per cortex call (calls are split evenly over threads).
    pub decode_batch: usize,
}

impl Default for ObserverSettings {
    fn default() -> Self {
        ObserverSettings {
            patch_radius_fraction: 0.125,
            fringe_cones: 1.5,
            peak_response: 0.6,
            noise_ratio: 0.0,
            decode_batch: 16,
        }
    }
}

/// Which percept a show is read out from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Readout {
    /// The learned cortex's decoded percept.
    Cortex,
    /// Baseline 1 of paper S-05: the percept *is* the ONS (Φ = identity, N = 1).
    OnsIdentity,
}

/// Retina + learned cortex as a CMF-SIM observer.
pub struct LearnedObserver<'a> {
    retina: &'a Retina,
    cortex: Option<&'a Cortex>,
    settings: ObserverSettings,
    readout: Readout,
    grid: WavelengthGrid,
    intensity: f64,
    levels: usize,
    /// Planes the cones read (the mosaic's classes).
    k_read: usize,
    /// Per location: the ONS basis and the readout cones.
    cache: Mutex<LocationCache>,
}

thread_local! {
    /// Each thread's decoding tape (with its buffer pool) and ONS buffer, kept between calls:
    /// CMF-SIM makes many small calls, and fresh pages per call would dominate them. (A tape
    /// holds `dyn Op`s and is not `Send`, so it lives in the rayon worker threads.)
    /// Taken out while in use (a nested rayon job on the same thread then makes its own).
    static WORKSPACE: std::cell::Cell<Option<(Tape<f32>, Vec<f32>)>> =
        const { std::cell::Cell::new(None) };
}

impl<'a> LearnedObserver<'a> {
    /// An observer reading the cortex's percept.
    pub fn new(retina: &'a Retina, cortex: &'a Cortex, settings: ObserverSettings) -> Self {
        Self::build(retina, Some(cortex), settings, Readout::Cortex)
    }

    /// Baseline 1 (S-05): the ONS itself is the percept.
    pub fn ons_identity(retina: &'a Retina, settings: ObserverSettings) -> Self {
        Self::build(retina, None, settings, Readout::OnsIdentity)
    }

    fn build(
        retina: &'a Retina,
        cortex: Option<&'a Cortex>,
        settings: ObserverSettings,
        readout: Readout,
    ) -> Self {
        let grid = retina.pool.projection.grid.clone();
        // Equal-energy monochromatic lights: find the largest class response over the grid.
        let projection = &retina.pool.projection;
        let mut peak = 0f64;
        for i in 0..grid.len() {
            let mut spectrum = vec![0.0; grid.len()];
            spectrum[i] = 1.0;
            let planes = projection.projector.project_spectrum(&spectrum);
            peak = peak.max(planes[..projection.k].iter().cloned().fold(0.0, f64::max));
        }
        let intensity = settings.peak_response / peak.max(1e-12);
        let levels = retina.cones.sampler.levels_needed();
        let k_read = retina.cones.weights.len() / (retina.n() * retina.n()).max(1);
        LearnedObserver {
            retina,
            cortex,
            settings,
            readout,
            grid,
            intensity,
            levels,
            k_read,
            cache: Mutex::new(LocationCache::default()),
        }
    }

    fn field_px(&self) -> usize {
        self.retina.layout.field_px
    }

    fn radius_px(&self) -> f64 {
        self.settings.patch_radius_fraction * self.field_px() as f64
    }

    /// Lattice indices of the cones read out for a patch centred at `centre_px`.
    fn cones_inside(&self, centre_px: [f64; 2]) -> Vec<usize> {
        let layout = &self.retina.layout;
        let spacing = layout.field_px as f64 / layout.n as f64;
        let r = (self.radius_px() - self.settings.fringe_cones * spacing).max(spacing);
        let mut inside: Vec<usize> = (0..layout.n * layout.n)
            .filter(|&i| {
                let p = layout.positions_px[i];
                let (dx, dy) = (p[0] as f64 - centre_px[0], p[1] as f64 - centre_px[1]);
                dx * dx + dy * dy <= r * r
            })
            .collect();
        if inside.is_empty() {
            // Fall back to the single nearest cone, so a percept always exists.
            let nearest = (0..layout.n * layout.n)
                .min_by(|&a, &b| {
                    let d = |i: usize| {
                        let p = layout.positions_px[i];
                        (p[0] as f64 - centre_px[0]).powi(2) + (p[1] as f64 - centre_px[1]).powi(2)
                    };
                    d(a).total_cmp(&d(b))
                })
                .expect("a layout has cones");
            inside.push(nearest);
        }
        inside
    }

    fn centre_px(&self, location: [f64; 2]) -> [f64; 2] {
        let half = self.field_px() as f64 / 2.0;
        [half + location[0] * half, half + location[1] * half]
    }

    /// Class-plane values of a show's stimulus.
    fn plane_values(&self, show: &Show) -> Vec<f64> {
        let spectrum = show.stimulus.to_grid(&self.grid);
        self.retina
            .pool
            .projection
            .projector
            .project_spectrum(&spectrum)
    }

    /// The ONS frame `(n·n)` of one show, rendered directly (noise as configured).
    pub fn render_ons(&self, show: &Show) -> Vec<f32> {
        self.render_planes(&self.plane_values(show), show.location, show.noise_seed)
    }

    /// The ONS of a disc with class-plane values `values` at `location`.
    fn render_planes(&self, values: &[f64], location: [f64; 2], noise_seed: u64) -> Vec<f32> {
        let projection = &self.retina.pool.projection;
        let n_planes = projection.n_planes();
        let f = self.field_px();
        let centre = self.centre_px(location);
        let radius = self.radius_px();
        let mut planes = vec![0f32; n_planes * f * f];
        for y in 0..f {
            for x in 0..f {
                let d = ((x as f64 + 0.5 - centre[0]).powi(2)
                    + (y as f64 + 0.5 - centre[1]).powi(2))
                .sqrt();
                let cover = (radius + 0.5 - d).clamp(0.0, 1.0) as f32;
                if cover > 0.0 {
                    for (p, &v) in values.iter().enumerate() {
                        planes[(p * f + y) * f + x] = cover * v as f32;
                    }
                }
            }
        }
        let stack = MipStack::compute(&planes, n_planes, f, f, self.levels);
        let nn = self.retina.n() * self.retina.n();
        let (mut act, mut ons) = (vec![0f32; nn], vec![0f32; nn]);
        if self.settings.noise_ratio > 0.0 {
            let mut rng = rand::rngs::SmallRng::seed_from_u64(noise_seed);
            self.retina.encode_frame_noisy(
                &mut rng,
                self.settings.noise_ratio,
                &stack,
                [0, 0],
                &mut act,
                &mut ons,
            );
        } else {
            self.retina.encode_frame(&stack, [0, 0], &mut act, &mut ons);
        }
        ons
    }

    /// The cached basis and readout of `location` (computed on first use).
    fn location_entry(&self, location: [f64; 2]) -> Arc<LocationEntry> {
        let key = [location[0].to_bits(), location[1].to_bits()];
        if let Some(e) = self.cache.lock().expect("cache lock").entries.get(&key) {
            return e.clone();
        }
        let nn = self.retina.n() * self.retina.n();
        let n_planes = self.retina.pool.projection.n_planes();
        let mut basis = Vec::with_capacity(self.k_read * nn);
        for c in 0..self.k_read {
            let mut unit = vec![0.0; n_planes];
            unit[c] = 1.0;
            basis.extend(self.render_planes(&unit, location, 0));
        }
        let entry = Arc::new(LocationEntry {
            basis,
            inside: self.cones_inside(self.centre_px(location)),
        });
        let bytes = entry.basis.len() * 4 + entry.inside.len() * 8;
        let mut cache = self.cache.lock().expect("cache lock");
        if cache.bytes + bytes <= CACHE_LIMIT_BYTES {
            cache.bytes += bytes;
            cache.entries.insert(key, entry.clone());
        }
        entry
    }

    /// Write the ONS of `show` into `ons (n·n)`; returns the readout cones.
    fn ons_into(&self, show: &Show, ons: &mut [f32]) -> Arc<LocationEntry> {
        let entry = self.location_entry(show.location);
        if self.settings.noise_ratio > 0.0 {
            ons.copy_from_slice(&self.render_ons(show));
            return entry;
        }
        let values = self.plane_values(show);
        let nn = ons.len();
        ons.fill(0.0);
        for (c, &v) in values[..self.k_read].iter().enumerate() {
            if v != 0.0 {
                let v = v as f32;
                for (o, b) in ons.iter_mut().zip(&entry.basis[c * nn..(c + 1) * nn]) {
                    *o += v * b;
                }
            }
        }
        entry
    }
}

impl Observer for LearnedObserver<'_> {
    fn name(&self) -> String {
        match self.readout {
            Readout::Cortex => format!("retina {} + learned cortex", self.retina.mosaic.spec_text),
            Readout::OnsIdentity => format!(
                "retina {} + identity (percept = ONS)",
                self.retina.mosaic.spec_text
            ),
        }
    }

    fn grid(&self) -> &WavelengthGrid {
        &self.grid
    }

    fn percept_dim(&self) -> usize {
        match (self.readout, self.cortex) {
            (Readout::Cortex, Some(c)) => c.percept_dim(),
            _ => 1,
        }
    }

    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        let dim = self.percept_dim();
        let nn = self.retina.n() * self.retina.n();
        assert_eq!(
            out.len(),
            shows.len() * dim,
            "LearnedObserver::percepts: out has {} values for {} shows",
            out.len(),
            shows.len()
        );
        if shows.is_empty() {
            return;
        }
        // Even jobs over the threads, none larger than decode_batch.
        let threads = rayon::current_num_threads().max(1);
        let jobs = shows
            .len()
            .div_ceil(self.settings.decode_batch.max(1))
            .max(threads);
        let chunk = shows.len().div_ceil(jobs).max(1);
        let n = self.retina.n();
        out.par_chunks_mut(chunk * dim)
            .zip(shows.par_chunks(chunk))
            .for_each(|(out, shows)| {
                let (mut tape, mut ons) = WORKSPACE
                    .take()
                    .unwrap_or_else(|| (Tape::new(), Vec::new()));
                {
                    let (tape, ons) = (&mut tape, &mut ons);
                    ons.clear();
                    ons.resize(shows.len() * nn, 0.0);
                    let entries: Vec<Arc<LocationEntry>> = shows
                        .iter()
                        .zip(ons.chunks_exact_mut(nn))
                        .map(|(show, o)| self.ons_into(show, o))
                        .collect();
                    let percept: &[f32] = match (self.readout, self.cortex) {
                        (Readout::Cortex, Some(c)) => {
                            tape.clear();
                            let o = tape.constant_from([shows.len(), 1, n, n], ons);
                            let (v, _, _) = c.record_decode(tape, o, &mut Marks::default());
                            tape.value(v).data()
                        }
                        _ => &ons[..],
                    };
                    for (s, entry) in entries.iter().enumerate() {
                        let inside = &entry.inside;
                        for d in 0..dim {
                            let plane = &percept[(s * dim + d) * nn..(s * dim + d + 1) * nn];
                            let mean = inside.iter().map(|&i| plane[i] as f64).sum::<f64>()
                                / inside.len() as f64;
                            out[s * dim + d] = mean;
                        }
                    }
                }
                tape.clear();
                WORKSPACE.set(Some((tape, ons)));
            });
    }

    fn stimulus_intensity(&self) -> f64 {
        self.intensity
    }

    /// The class planes the cones read: the eye sees a spectrum only through them (with or
    /// without noise, whose seed is the show's).
    fn linear_front_end(&self) -> Option<Vec<Vec<f64>>> {
        let g = self.grid.len();
        let projector = &self.retina.pool.projection.projector;
        let mut rows = vec![vec![0.0; g]; self.k_read];
        for i in 0..g {
            let mut spectrum = vec![0.0; g];
            spectrum[i] = 1.0;
            let planes = projector.project_spectrum(&spectrum);
            for (row, v) in rows.iter_mut().zip(&planes) {
                row[i] = *v;
            }
        }
        Some(rows)
    }

    fn location_pair(&self, rng: &mut dyn RngCore) -> [[f64; 2]; 2] {
        use rand::Rng;
        // Keep the whole disc (plus a lateral-inhibition margin) inside the field, and the two
        // patches at least two diameters apart when the field allows it.
        let margin = 2.0 * self.settings.patch_radius_fraction * 1.25;
        let lim = (1.0 - margin).max(0.05);
        let min_distance = (4.0 * self.settings.patch_radius_fraction * 2.0).min(lim);
        let mut draw = || [rng.random_range(-lim..lim), rng.random_range(-lim..lim)];
        let a = draw();
        for _ in 0..1000 {
            let b = draw();
            if ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt() >= min_distance {
                return [a, b];
            }
        }
        [a, [-a[0], -a[1]]]
    }
}

#[cfg(test)]
mod tests {
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

    #[test]
    fn linear_combination_rendering_equals_direct_rendering() {
        let (retina, cortex) = tiny();
        let o = LearnedObserver::new(&retina, &cortex, ObserverSettings::default());
        let nn = retina.n() * retina.n();
        for show in shows() {
            let direct = o.render_ons(&show);
            let mut combined = vec![0f32; nn];
            o.ons_into(&show, &mut combined);
            let scale = direct.iter().fold(0f32, |m, v| m.max(v.abs())).max(1e-30);
            let worst = direct
                .iter()
                .zip(&combined)
                .map(|(a, b)| (a - b).abs())
                .fold(0f32, f32::max);
            assert!(
                worst <= 1e-5 * scale,
                "{:?}: max |Δ| {worst} vs max |ONS| {scale}",
                show.stimulus
            );
        }
    }

    #[test]
    fn percepts_do_not_depend_on_batching_or_the_cache() {
        let (retina, cortex) = tiny();
        let shows = shows();
        let o = LearnedObserver::new(&retina, &cortex, ObserverSettings::default());
        let dim = o.percept_dim();
        let mut all = vec![0.0; shows.len() * dim];
        o.percepts(&shows, &mut all);
        // one show per call, on a fresh observer (cold cache)
        let single = LearnedObserver::new(&retina, &cortex, ObserverSettings::default());
        for (s, show) in shows.iter().enumerate() {
            let mut one = vec![0.0; dim];
            single.percepts(std::slice::from_ref(show), &mut one);
            for d in 0..dim {
                let (a, b) = (all[s * dim + d], one[d]);
                assert!(
                    (a - b).abs() <= 1e-5 * a.abs().max(1e-3),
                    "show {s} channel {d}: {a} vs {b}"
                );
            }
        }
    }
}
