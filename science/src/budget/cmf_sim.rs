//! CMF-SIM's memory from its shapes: what grows with `cmf_sim.location_pairs` (P) and
//! `cmf_sim.n_test_wavelengths` (W) beyond the observer's decodes.
//!
//! Step 1 (`colorimetry::cmf_sim::base`) shows every test light at both locations of every pair
//! of every wavelength: 3·W·P shows (a `Show`, and one heap line of a monochromatic light for
//! the two lit ones), their readouts `(3·W·P, R)` f64, then the same readouts again split into
//! Φ(test at a), Φ(black at b), Φ(test at b), kept for the search (R: the readout length,
//! samples × percept channels). The observer caches per location (`science::observer`, at most
//! [`crate::observer::CACHE_LIMIT_BYTES`] of bases) the ONS of a unit disc per class read,
//! `(classes × n²)` f32 for the cortex, beside the cones it reads; the 2·W·P locations are all
//! distinct (drawn per wavelength).

use crate::config::RunConfig;
use crate::observer::Readout;
use colorimetry::cmf_sim::CmfSimSettings;
use retina::foveation::ConeLayout;

/// A `Show` (stimulus enum 32, location 16, seed 8), bytes.
const SHOW_BYTES: f64 = 56.0;
/// The heap line `(wavelength, intensity)` of a lit show: 16 bytes in the allocator's
/// smallest chunk, bytes.
const LINE_BYTES: f64 = 32.0;
/// A cached location's bookkeeping besides its basis and cells: the entry (three `Vec`
/// headers) in its `Arc` (two counters), its hash-map slot (key 16, pointer 8) at the map's
/// lowest load (half full after a doubling), and its cells' allocation header, bytes.
const ENTRY_BYTES: f64 = 72.0 + 16.0 + 2.0 * 24.0 + 16.0;

/// Readout samples of the observer of `config` (`observer.readout`, patch and spacing).
fn readout_samples(config: &RunConfig, layout: &ConeLayout) -> usize {
    let o = &config.observer;
    let readout = Readout::new(
        o.readout,
        layout,
        o.patch_radius_fraction * layout.field_px as f64,
        o.fringe_cones,
        o.sample_spacing_cones,
    );
    readout.samples()
}

/// Bytes CMF-SIM with `settings` holds beyond the decodes, on the cortex of `config`.
pub fn bytes(config: &RunConfig, settings: &CmfSimSettings, layout: &ConeLayout) -> f64 {
    let r = &config.retina;
    let classes = retina::MosaicSpec::parse(&config.cones)
        .map(|s| s.class_names().len())
        .unwrap_or(3) as f64;
    let n2 = (r.cones_per_side as f64).powi(2);
    let samples = readout_samples(config, layout) as f64;
    let readout_len = samples * config.cortex.percept_dim() as f64;
    let pairs = settings.n_test_wavelengths as f64 * settings.location_pairs as f64;
    let shows = 3.0 * pairs;
    let base = shows * (SHOW_BYTES + 8.0 * readout_len)
        + 2.0 * pairs * LINE_BYTES
        + shows * 8.0 * readout_len;
    let locations = 2.0 * pairs;
    let basis = classes * n2 * 4.0;
    let limit = crate::observer::CACHE_LIMIT_BYTES as f64;
    let cached = locations.min((limit / basis).floor());
    let cache = cached * (basis + ENTRY_BYTES + samples * 8.0);
    base + cache
}
