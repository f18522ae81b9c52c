//! (being written)
pub const OPS: &[&str] = &[];
