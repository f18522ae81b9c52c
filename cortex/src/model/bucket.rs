//! The parts of the cortex a step is timed and credited by — the buckets W, C, D, P, M and the
//! loss — and how a tape scope or a parameter name maps to one (its name up to the first `.`).

use autodiff::Tape;

/// The parts of a step that are timed separately.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Bucket {
    W = 0,
    C = 1,
    D = 2,
    P = 3,
    M = 4,
    Loss = 5,
}

/// Number of [`Bucket`]s.
pub const BUCKETS: usize = 6;
/// Names of the buckets, indexed by `Bucket as usize`.
pub const BUCKET_NAMES: [&str; BUCKETS] = ["W", "C", "D", "P", "M", "loss"];

/// Tags of decode Φ's W and C outputs, in forward order: decoded activations, injected
/// colour (the U-Net tags its own layers, the percept included).
pub const TAGS: [&str; 2] = ["cortex.w.decoded", "cortex.c.injected"];

/// The bucket a scope belongs to: the part of its name before the first `.` (`D.inc` → D),
/// when that is a bucket's name.
pub fn bucket_of_scope(scope: &str) -> Option<Bucket> {
    let head = scope.split('.').next().unwrap_or(scope);
    BUCKET_NAMES
        .iter()
        .position(|&b| b == head)
        .map(|i| BUCKETS_IN_ORDER[i])
}

/// The learned bucket a parameter belongs to, from its name (`w.response` → W, `d.…` → D).
pub fn bucket_of_param(name: &str) -> Option<Bucket> {
    match name.split('.').next() {
        Some("w") => Some(Bucket::W),
        Some("c") => Some(Bucket::C),
        Some("d") => Some(Bucket::D),
        Some("p") => Some(Bucket::P),
        _ => None,
    }
}

/// The buckets in index order.
pub const BUCKETS_IN_ORDER: [Bucket; BUCKETS] = [
    Bucket::W,
    Bucket::C,
    Bucket::D,
    Bucket::P,
    Bucket::M,
    Bucket::Loss,
];

/// The buckets that hold parameters, in order.
pub const LEARNED_BUCKETS: [Bucket; 4] = [Bucket::W, Bucket::C, Bucket::D, Bucket::P];

pub(crate) fn enter(tape: &mut Tape<f32>, b: Bucket) {
    tape.enter_scope(BUCKET_NAMES[b as usize]);
}
