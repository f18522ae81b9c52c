//! CMF-SIM's memory from its shapes: what grows with `cmf_sim.location_pairs` (P) and
//! `cmf_sim.n_test_wavelengths` (W) beyond the observer's decodes.
//!
//! Step 1 (`colorimetry::cmf_sim::base`) shows every test light at both locations of every pair
//! of every wavelength: 3·W·P shows (a `Show`, and one heap line of a monochromatic light for
//! the two lit ones), their readouts `(3·W·P, R)` f64, then the same readouts again split into
//! Φ(test at a), Φ(black at b), Φ(test at b), kept for the search (R: the readout length,
//! samples × percept channels). The observer caches per location (`science::observer`, at most
//! [`crate::observer::CACHE_LIMIT_BYTES`] of bases) the ONS of a unit disc per class read,
//! `(classes × n²)` f32, or for the cortex the activations of that ONS on its decode window,
//! `(classes × window)` f32 (the largest window a patch needs, [`decode_pixels`]: on the
//! 256 × 256 eye 200 × 200; most patches need 160 × 160), beside the cones it reads (and, for
//! the cortex, their indices in the window it decodes); the 2·W·P locations are all distinct
//! (drawn per wavelength).
//!
//! The search (`colorimetry::matching`) adds, with K = `max_primaries` and m = classes:
//! - the front end's model (`FrontEndJacobians`), kept for every wavelength once measured:
//!   `G_a`, `G_b` and the offset, `W·P·R·(2m + 1)` f64; measuring it shows `2m` spectra per
//!   (wavelength, pair), each a full grid of f64, and reads their readouts (`2m·R` f64 each);
//! - one Levenberg–Marquardt state per wavelength solved at once (`matching::state`): the two
//!   sides' readouts at α and at the trial, the model's offset and the two Jacobians,
//!   `P·R·(5 + 2K)` f64 a wavelength;
//! - the Jacobian pass's `2K` shows per (wavelength, pair) and their readouts;
//! - the resume states of the set being converged, kept for all its wavelengths (`W·P·R·2`
//!   f64; a resumed solve copies them into its own state).
//!
//! The wavelengths are solved in groups whose states and Jacobian pass fit
//! `colorimetry::cmf_sim::sets::SOLVE_GROUP_BYTES` ([`wavelengths_per_group`]; every
//! wavelength at once at the quick eye's defaults), and a group's front-end shows are measured
//! just before it: so the states, the pass and the front end's shows are one group's, and at
//! the tops of `location_pairs` and `n_test_wavelengths` the search's memory stops growing with
//! K — what a cortex whose search stops at K = 1 holds is what one that tries K = 4 holds.
//! The front end's shows end before the states begin, so the larger of the two counts. Step 1
//! ends before the search begins: its shows and the readouts as returned are freed, the split
//! readouts stay, so the larger of step 1 and (split readouts + search) counts. K is the most
//! primaries the search can try: `max_primaries`, or for the analytic observer (an ideal eye,
//! whose dimension is its classes by construction: any m independent primaries match every
//! light exactly) at most its m classes, since the search stops at the first K that passes.
//! Measured on the analytic observer at `location_pairs = 4096` (`tiny`, one thread; heap
//! profile in docs/memory-tops.md): the Jacobian pass of K = 3 holds 2K shows per (wavelength,
//! pair) in a vector grown to the next power of two, its index of them (likewise), their heap
//! lines and readouts: the model counts these shapes. Not counted: the resume states that the
//! other tried sets keep for the few wavelengths their early rejection stopped below the
//! threshold (`2·P·R` f64 each).

use crate::config::RunConfig;
use crate::observer::{oracle::ORACLE_PERCEPT_DIM, ObserverKind, Readout};
use colorimetry::cmf_sim::sets::wavelengths_per_group;
use colorimetry::cmf_sim::CmfSimSettings;
use retina::foveation::ConeLayout;

/// A `Show` (stimulus enum 32, location 16, seed 8), bytes.
const SHOW_BYTES: f64 = 56.0;
/// An entry of the Jacobian pass's index of its shows (state, pair, primary, side, show),
/// bytes.
const INDEX_BYTES: f64 = 40.0;
/// The heap line `(wavelength, intensity)` of a lit show: 16 bytes in the allocator's
/// smallest chunk, bytes.
const LINE_BYTES: f64 = 32.0;
/// A cached location's bookkeeping besides its basis and cells: the entry (its vectors'
/// headers and the cortex's window) in its `Arc` (two counters), its hash-map slot (key 16,
/// pointer 8) at the map's lowest load (half full after a doubling), and the allocator's header
/// of its four allocations (the `Arc`, the cells, the basis, the window's indices), bytes.
const ENTRY_BYTES: f64 =
    crate::observer::LOCATION_ENTRY_BYTES as f64 + 16.0 + 2.0 * 24.0 + 4.0 * 16.0;

/// The readout of the observer of `config` (`observer.readout`, patch and spacing).
fn readout(config: &RunConfig, layout: &ConeLayout) -> Readout {
    let o = &config.observer;
    Readout::new(
        o.readout,
        layout,
        o.patch_radius_fraction * layout.field_px as f64,
        o.fringe_cones,
        o.sample_spacing_cones,
    )
}

/// Readout samples of the observer of `config`.
fn readout_samples(config: &RunConfig, layout: &ConeLayout) -> usize {
    readout(config, layout).samples()
}

/// The ONS pixels one show's decode by the cortex covers: the largest window D's encoder runs
/// on for a patch's cells (`cortex::window::longest_window` of the largest box of cells a patch
/// reads, over the field's centre and the eight places a patch centre may lie nearest its
/// border, where a foveated mosaic's patches hold the most and the fewest cones). On the quick
/// eye it is the whole field; on the 256 × 256 eye 200 × 200 (most of its patches are decoded
/// on 160 × 160 windows; 200 × 200 is the largest over the placements and the pooling grid's
/// offsets).
pub fn decode_pixels(config: &RunConfig, layout: &ConeLayout) -> f64 {
    let readout = readout(config, layout);
    let n = layout.n;
    let (mid, half) = (
        (layout.field_px as f64 - 1.0) / 2.0,
        layout.field_px as f64 / 2.0,
    );
    let edge = 1.0 - colorimetry::observer::DEFAULT_BORDER_MARGIN;
    let mut longest = (0, 0);
    for x in [-edge, 0.0, edge] {
        for y in [-edge, 0.0, edge] {
            let cells = readout.cells(layout, [mid + x * half, mid + y * half]);
            let Some((rows, cols)) = crate::observer::readout::cells_box(&cells, n) else {
                continue;
            };
            let (h, w) = cortex::window::longest_window(
                &config.cortex,
                rows[1] - rows[0] + 1,
                cols[1] - cols[0] + 1,
                n,
            );
            longest = (longest.0.max(h), longest.1.max(w));
        }
    }
    if longest == (0, 0) {
        return (n * n) as f64;
    }
    (longest.0 * longest.1) as f64
}

/// Length of one show's readout by observer `kind`, f64s: samples × the decoder's percept
/// channels (`science::observer::Decoder::dim`), or the cone classes of the analytic observer
/// (no mosaic, one value per class).
pub fn readout_len(config: &RunConfig, layout: &ConeLayout, kind: ObserverKind) -> usize {
    let samples = readout_samples(config, layout);
    match kind {
        ObserverKind::Cortex => samples * config.cortex.percept_dim(),
        ObserverKind::Identity | ObserverKind::Cones => samples,
        ObserverKind::Oracle | ObserverKind::OracleMosaic => samples * ORACLE_PERCEPT_DIM,
        ObserverKind::Analytic => classes(config),
    }
}

/// The cone classes of `config`'s eye.
fn classes(config: &RunConfig) -> usize {
    retina::MosaicSpec::parse(&config.cones)
        .map(|s| s.class_names().len())
        .unwrap_or(3)
}

/// Bytes CMF-SIM with `settings` holds beyond the decodes, on observer `kind` through the eye
/// of `config` (the analytic observer has no eye, so no per-location cache). `window_px`: the
/// ONS pixels the cortex keeps a location's basis on ([`decode_pixels`], computed once by the
/// caller); other observers keep the whole field and ignore it.
pub fn bytes(
    config: &RunConfig,
    settings: &CmfSimSettings,
    layout: &ConeLayout,
    kind: ObserverKind,
    window_px: f64,
) -> f64 {
    let r = &config.retina;
    let classes = classes(config) as f64;
    let n2 = (r.cones_per_side as f64).powi(2);
    let samples = readout_samples(config, layout) as f64;
    let readout_len = readout_len(config, layout, kind) as f64;
    let pairs = settings.n_test_wavelengths as f64 * settings.location_pairs as f64;
    let shows = 3.0 * pairs;
    // Step 1: the shows and their readouts as returned, then split (the split copy is kept).
    let split = shows * 8.0 * readout_len;
    let step1 = shows * (SHOW_BYTES + 8.0 * readout_len) + 2.0 * pairs * LINE_BYTES + split;
    let locations = 2.0 * pairs;
    // The cache stops at its limit as it counts an entry (`science::observer::render::
    // location_entry`: the unit-disc responses and 16 bytes a cell read); beside the cells read
    // the cortex keeps their indices in the window it decodes (`decode_window`). The responses
    // are reserved exactly, one plane per class.
    // The cortex keeps each location's activations on its decode window, other observers the
    // ONS of the whole field.
    let pixels = match kind {
        ObserverKind::Cortex => window_px,
        _ => n2,
    };
    let basis = classes * pixels * 4.0;
    let counted = basis + samples * 16.0;
    let limit = crate::observer::CACHE_LIMIT_BYTES as f64;
    let cached = match kind {
        ObserverKind::Analytic => 0.0,
        _ => locations.min((limit / counted).floor()),
    };
    let indices = if kind == ObserverKind::Cortex {
        2.0
    } else {
        1.0
    };
    let cache = cached * (basis + ENTRY_BYTES + indices * samples * 8.0);
    let grid_len = config.retina.grid.grid().map(|g| g.len()).unwrap_or(0) as f64;
    let primaries = primaries_tried(settings, kind, classes);
    // The analytic observer offers no linear front end (`Observer::linear_front_end`).
    let front_end = settings.front_end_jacobians && kind != ObserverKind::Analytic;
    let wavelengths = settings.n_test_wavelengths as f64;
    let pairs_each = settings.location_pairs as f64;
    let search = search_bytes(
        front_end,
        primaries,
        classes,
        [wavelengths, pairs_each],
        readout_len,
        grid_len,
    );
    cache + step1.max(split + search)
}

/// The most primaries CMF-SIM may try on observer `kind` with `classes` cone classes: its
/// `max_primaries`, or at most the classes for the analytic observer (module docs).
fn primaries_tried(settings: &CmfSimSettings, kind: ObserverKind, classes: f64) -> f64 {
    let k = settings.max_primaries as f64;
    match kind {
        ObserverKind::Analytic => k.min(classes),
        _ => k,
    }
}

/// Bytes of the search's solver (module docs) trying up to `k` primaries, with the front end's
/// model when `front_end`, for `classes` cone classes over `wavelengths` × `pairs` (wavelength,
/// location pair)s, each read as `readout_len` f64, on a grid of `grid_len` wavelengths. The
/// solves run in groups of [`wavelengths_per_group`] wavelengths: the states, the Jacobian pass
/// and the front end's shows are one group's.
fn search_bytes(
    front_end: bool,
    k: f64,
    classes: f64,
    [wavelengths, pairs]: [f64; 2],
    readout_len: f64,
    grid_len: f64,
) -> f64 {
    let rows = wavelengths * pairs * readout_len;
    let group = wavelengths_per_group(k as usize, pairs as usize, readout_len as usize) as f64;
    let solved = wavelengths.min(group) * pairs;
    let group_rows = solved * readout_len;
    let (front_end_kept, front_end_shows) = if front_end {
        let shows = solved * 2.0 * classes;
        (
            rows * (2.0 * classes + 1.0) * 8.0,
            shows * (SHOW_BYTES + 8.0 * grid_len + 8.0 * readout_len),
        )
    } else {
        (0.0, 0.0)
    };
    let states = group_rows * (5.0 + 2.0 * k) * 8.0;
    // The pass's shows and its index of them are vectors grown by doubling: their capacity is
    // the next power of two; each show's heap line holds up to max(K, 4) (wavelength,
    // intensity) pairs and the allocator's header.
    let n = solved * 2.0 * k;
    let capacity = 2f64.powf(n.max(1.0).log2().ceil());
    let line = 16.0 * k.max(4.0) + 16.0;
    let jacobian_shows = capacity * (SHOW_BYTES + INDEX_BYTES) + n * line;
    let jacobian_readouts = group_rows * 2.0 * k * 8.0;
    // A converged set's resume states (both sides' readouts of every wavelength), kept while
    // its solves are continued group by group.
    let resume_kept = rows * 2.0 * 8.0;
    front_end_kept + resume_kept + front_end_shows.max(states + jacobian_shows + jacobian_readouts)
}
