//! The black-box colour observers CMF-SIM probes: the simulated eye followed by a decoder (paper
//! S-04: "the retina model plus learned cortical model as a black-box color observer").
//!
//! One show (a spectral stimulus at a location) goes through:
//! - **Stimulus.** A disc of radius `patch_radius_fraction × field side` on a black background,
//!   centred at the show's location (`[-1, 1]²` over the field, x to the right, y down), rendered
//!   by [`Retina::encode_disc`] at an intensity that puts the largest single-class response to
//!   an equal-energy monochromatic light at `peak_response`.
//! - **Eye.** One frame, no eye motion: cone sampling at the true positions, lateral inhibition,
//!   noise with ratio `noise_ratio` (0: noise-free), seeded by the show's `noise_seed`.
//! - **Decoder** ([`Decoder`]): the learned cortex Φ; or a known-answer decoder that calibrates
//!   CMF-SIM — the ONS itself (paper S-05 baseline 1), the cone activations before lateral
//!   inhibition (baseline 2), or an oracle built from the true eye ([`oracle`]).
//! - **Readout** ([`readout`]): the percept compared point by point in patch-relative
//!   coordinates (default), or its patch mean. Evaluation may use ground truth (true cone
//!   positions pick the cones read); learning never does.
//!
//! **Speed.** Without noise the eye is linear ([`retina::stimulus`], a tested property), so the
//! ONS of a stimulus at a location is `Σ_c v_c · B_c` with `v` its class-plane values and `B_c`
//! the ONS of a unit disc on plane c there. Each location keeps its `B_c` (for the cortex) or,
//! for the decoders that are linear too, the readouts of `B_c` themselves; CMF-SIM shows every
//! location many times. With noise every show is rendered and decoded. The cortex decodes in
//! rayon jobs of at most `decode_batch` shows, split evenly over the threads, and runs its
//! decoder D only on the window that the patch's read cones depend on
//! ([`cortex::Cortex::record_decode_windows`]), and D's up blocks only where the box of those
//! cones reaches (`cortex::OutputBox`): the percepts are the whole field's, at a fraction of
//! the cost on a large eye (a patch of the 256 × 256 eye needs a 160 × 160 window).
//! W's inverse is linear too, so without noise each location keeps, for the windowed cortex,
//! the cone activations W's inverse makes of each `B_c`, cut to its window, instead of `B_c`:
//! a show's activations are their weighted sum, and W's Fourier filter runs once per location
//! and plane, not once per show ([`cortex::Cortex::record_decode_activation_windows`]).
//!
//! **Decoders from outside** ([`ExternalDecoder`]: a batch function, e.g. a Python model) are
//! nonlinear observers by construction: only the eye's own linearity is used (the ONS of a show
//! is rendered from the unit-disc responses), never a cached readout, and the observer offers no
//! linear front end, so CMF-SIM shows every primary. Their percepts are checked for shape and
//! finite values; a failure stops CMF-SIM and is its error ([`crate::measure::measure_decoder_until`]).

mod mixed_opsins;
pub mod oracle;
pub mod readout;
mod render;
pub(crate) use render::LOCATION_ENTRY_BYTES;
mod settings;
#[cfg(test)]
mod tests;

pub use oracle::OracleDecoder;
pub use readout::{Readout, ReadoutMode};
pub use render::external::{BatchDecodeFn, ExternalDecoder};
use render::LocationCache;
pub use settings::ObserverSettings;

use autodiff::Tape;
use colorimetry::observer::{Observer, Show};
use colorimetry::WavelengthGrid;
use cortex::Cortex;
use rand::RngCore;
use rayon::prelude::*;
use retina::{Disc, NoiseDraw, Retina};
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// Largest total size of the per-location cache, bytes (beyond it, shows render directly).
pub const CACHE_LIMIT_BYTES: usize = 1 << 30;

/// The observers CMF-SIM tests through an eye: the learned cortex, or one whose colour
/// dimension is known ([`crate::ladder`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObserverKind {
    /// The learned cortex of a trained run.
    Cortex,
    /// Φ = identity: the optic nerve signal is the percept (no colour constancy).
    Identity,
    /// The cone activations are the percept, lateral inhibition omitted (1).
    Cones,
    /// Oracle decoder: each kind of cone interpolated across the mosaic (as many dimensions as
    /// independent kinds; cones mixing opsins solved by least squares over the mixtures).
    Oracle,
    /// Oracle decoder, each cell keeping only its own kind (no demosaicking).
    OracleMosaic,
    /// The cone excitations of an ideal eye with these cones: no mosaic, no noise.
    Analytic,
}

impl ObserverKind {
    /// Every kind, in the order the command line lists them.
    pub const ALL: [ObserverKind; 6] = [
        ObserverKind::Cortex,
        ObserverKind::Identity,
        ObserverKind::Cones,
        ObserverKind::Oracle,
        ObserverKind::OracleMosaic,
        ObserverKind::Analytic,
    ];

    /// The kind named `name` ([`ObserverKind::name`]).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|k| k.name() == name)
    }

    /// Its name on the command line and in folder names (`oracle-mosaic`).
    pub fn name(self) -> &'static str {
        match self {
            ObserverKind::Cortex => "cortex",
            ObserverKind::Identity => "identity",
            ObserverKind::Cones => "cones",
            ObserverKind::Oracle => "oracle",
            ObserverKind::OracleMosaic => "oracle-mosaic",
            ObserverKind::Analytic => "analytic",
        }
    }
}

/// What turns one ONS frame into a percept image.
pub enum Decoder<'a> {
    /// The learned cortex's decoder Φ (N channels).
    Cortex(&'a Cortex),
    /// Φ = identity: the percept is the ONS (1 channel; paper S-05 baseline 1).
    Ons,
    /// The percept is the cone activations, lateral inhibition omitted (1 channel; S-05
    /// baseline 2).
    Cones,
    /// An oracle built from the true eye ([`oracle`]).
    Oracle(OracleDecoder),
    /// A batch function from outside (a Python model): nonlinear, decoded in batches on the
    /// thread that asks for the percepts ([`ExternalDecoder`]).
    External(ExternalDecoder<'a>),
}

impl Decoder<'_> {
    /// Channels of the percept image.
    pub fn dim(&self) -> usize {
        match self {
            Decoder::Cortex(c) => c.percept_dim(),
            Decoder::Ons | Decoder::Cones => 1,
            Decoder::Oracle(_) => oracle::ORACLE_PERCEPT_DIM,
            Decoder::External(x) => x.dim(),
        }
    }

    /// Whether the percept is linear in the ONS: the known-answer decoders only (the cortex,
    /// an external decoder and any decoder added later are not).
    fn is_linear(&self) -> bool {
        matches!(self, Decoder::Ons | Decoder::Cones | Decoder::Oracle(_))
    }

    fn describe(&self) -> String {
        match self {
            Decoder::Cortex(_) => "learned cortex".into(),
            Decoder::External(x) => x.name().into(),
            Decoder::Ons => "identity (percept = ONS)".into(),
            Decoder::Cones => "cone activations (no lateral inhibition)".into(),
            Decoder::Oracle(o) if o.solves_mixtures() => format!(
                "oracle, {} opsin planes solved by least squares over cones of mixed opsins",
                o.kinds()
            ),
            Decoder::Oracle(o) => format!(
                "oracle, {} kinds of cone{}",
                o.kinds(),
                if o.interpolates() {
                    ", interpolated"
                } else {
                    ", each cell its own kind"
                }
            ),
        }
    }
}

/// The eye + a decoder as a CMF-SIM observer (module docs).
pub struct EyeObserver<'a> {
    retina: &'a Retina,
    decoder: Decoder<'a>,
    settings: ObserverSettings,
    readout: Readout,
    intensity: f64,
    cache: Mutex<LocationCache>,
    /// Whether the cortex decodes the whole field for every show rather than the window each
    /// patch needs (the same percepts; the reference the windows are tested against).
    whole_field: bool,
}

impl<'a> EyeObserver<'a> {
    /// The eye followed by `decoder`.
    pub fn new(retina: &'a Retina, decoder: Decoder<'a>, settings: ObserverSettings) -> Self {
        // Equal-energy monochromatic lights: find the largest class response over the grid.
        let (g, k) = (retina.grid().len(), retina.classes_read());
        let mut peak = 0f64;
        for i in 0..g {
            let mut spectrum = vec![0.0; g];
            spectrum[i] = 1.0;
            peak = peak.max(
                retina.class_values(&spectrum)[..k]
                    .iter()
                    .cloned()
                    .fold(0.0, f64::max),
            );
        }
        let readout = Readout::new(
            settings.readout,
            &retina.layout,
            settings.patch_radius_fraction * retina.layout.field_px as f64,
            settings.fringe_cones,
            settings.sample_spacing_cones,
        );
        EyeObserver {
            retina,
            decoder,
            intensity: settings.peak_response / peak.max(1e-12),
            settings,
            readout,
            cache: Mutex::new(LocationCache::default()),
            whole_field: false,
        }
    }

    /// The same observer, its cortex decoding the whole field for every show (module docs,
    /// **Speed**): the reference that windowed decoding is tested and timed against.
    pub fn decoding_whole_field(mut self) -> Self {
        self.whole_field = true;
        self
    }

    /// The eye followed by the learned cortex.
    pub fn cortex(retina: &'a Retina, cortex: &'a Cortex, settings: ObserverSettings) -> Self {
        Self::new(retina, Decoder::Cortex(cortex), settings)
    }

    /// The readout geometry.
    pub fn readout(&self) -> &Readout {
        &self.readout
    }

    /// Why an external decoder failed during the last measurement (an error it returned, a
    /// percept of the wrong length or a non-finite value); `None` for the other decoders.
    pub fn decoder_failure(&self) -> Option<String> {
        match &self.decoder {
            Decoder::External(x) => x.failure(),
            _ => None,
        }
    }

    fn disc(&self, location: [f64; 2]) -> Disc {
        let f = self.retina.layout.field_px as f64;
        let (mid, half) = ((f - 1.0) / 2.0, f / 2.0);
        Disc {
            centre_px: [mid + location[0] * half, mid + location[1] * half],
            radius_px: self.settings.patch_radius_fraction * f,
        }
    }

    fn noise(&self, seed: u64) -> Option<NoiseDraw> {
        (self.settings.noise_ratio > 0.0).then_some(NoiseDraw {
            ratio: self.settings.noise_ratio,
            seed,
        })
    }
}

impl Observer for EyeObserver<'_> {
    fn name(&self) -> String {
        format!(
            "retina {} + {}",
            self.retina.mosaic.spec_text,
            self.decoder.describe()
        )
    }

    fn grid(&self) -> &WavelengthGrid {
        self.retina.grid()
    }

    fn percept_dim(&self) -> usize {
        self.readout.len(self.decoder.dim())
    }

    fn percepts(&self, shows: &[Show], out: &mut [f64]) {
        let len = self.percept_dim();
        assert_eq!(
            out.len(),
            shows.len() * len,
            "EyeObserver::percepts: out has {} values for {} shows of {len}",
            out.len(),
            shows.len()
        );
        if shows.is_empty() {
            return;
        }
        if let Decoder::External(x) = &self.decoder {
            return self.external_percepts(x, shows, out);
        }
        // Even jobs over the threads, none larger than decode_batch.
        let threads = rayon::current_num_threads().max(1);
        let jobs = shows
            .len()
            .div_ceil(self.settings.decode_batch.max(1))
            .max(threads);
        let chunk = shows.len().div_ceil(jobs).max(1);
        out.par_chunks_mut(chunk * len)
            .zip(shows.par_chunks(chunk))
            .for_each(|(out, shows)| self.percepts_job(shows, out));
    }

    fn stimulus_intensity(&self) -> f64 {
        self.intensity
    }

    /// The class planes the cones read: the eye sees a spectrum only through them (with or
    /// without noise, whose seed is the show's). Built from unit spectra, one per wavelength:
    /// [`Retina::class_values`] is linear in the spectrum (a tested property).
    ///
    /// None for an external decoder: nothing about it is assumed (module docs).
    fn linear_front_end(&self) -> Option<Vec<Vec<f64>>> {
        if matches!(self.decoder, Decoder::External(_)) {
            return None;
        }
        let (g, k) = (self.retina.grid().len(), self.retina.classes_read());
        let mut rows = vec![vec![0.0; g]; k];
        for i in 0..g {
            let mut spectrum = vec![0.0; g];
            spectrum[i] = 1.0;
            for (row, v) in rows.iter_mut().zip(self.retina.class_values(&spectrum)) {
                row[i] = v;
            }
        }
        Some(rows)
    }

    fn location_pair(&self, rng: &mut dyn RngCore) -> [[f64; 2]; 2] {
        use rand::Rng;
        // Keep the whole disc (plus a lateral-inhibition margin) inside the field, and the two
        // patches at least two diameters apart when the field allows it.
        let radius = 2.0 * self.settings.patch_radius_fraction;
        let margin = match self.settings.edge_clearance_cones {
            None => radius * 1.25,
            Some(c) => radius + c * 2.0 / self.retina.config.cones_per_side as f64,
        };
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
