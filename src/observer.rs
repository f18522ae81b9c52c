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
    /// Shows decoded per cortex call.
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
        LearnedObserver {
            retina,
            cortex,
            settings,
            readout,
            grid,
            intensity,
            levels,
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

    /// The ONS frame `(n·n)` of one show (noise as configured).
    pub fn render_ons(&self, show: &Show) -> Vec<f32> {
        let projection = &self.retina.pool.projection;
        let spectrum = show.stimulus.to_grid(&self.grid);
        let values = projection.projector.project_spectrum(&spectrum);
        let n_planes = projection.n_planes();
        let f = self.field_px();
        let centre = self.centre_px(show.location);
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
            let mut rng = rand::rngs::SmallRng::seed_from_u64(show.noise_seed);
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
        let chunk = self.settings.decode_batch.max(1);
        // One tape per rayon job, cleared per chunk: its buffer pool makes decoding allocation-free
        // after the first chunk (fresh pages are expensive on these machines).
        out.par_chunks_mut(chunk * dim)
            .zip(shows.par_chunks(chunk))
            .for_each_init(Tape::<f32>::new, |tape, (out, shows)| {
                let ons: Vec<f32> = shows.iter().flat_map(|s| self.render_ons(s)).collect();
                let n = self.retina.n();
                let percept: &[f32] = match (self.readout, self.cortex) {
                    (Readout::Cortex, Some(c)) => {
                        tape.clear();
                        let o = tape.constant_from([shows.len(), 1, n, n], &ons);
                        let (v, _, _) = c.record_decode(tape, o, &mut Marks::default());
                        tape.value(v).data()
                    }
                    _ => &ons,
                };
                for (s, show) in shows.iter().enumerate() {
                    let inside = self.cones_inside(self.centre_px(show.location));
                    for d in 0..dim {
                        let plane = &percept[(s * dim + d) * nn..(s * dim + d + 1) * nn];
                        let mean = inside.iter().map(|&i| plane[i] as f64).sum::<f64>()
                            / inside.len() as f64;
                        out[s * dim + d] = mean;
                    }
                }
            });
    }

    fn stimulus_intensity(&self) -> f64 {
        self.intensity
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
