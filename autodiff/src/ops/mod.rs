//! Built-in ops, one family per file. Each file documents shapes and the derivative, adds
//! `Tape` methods for its ops (`tape.conv2d(..)`), and checks its gradients beside the code.
//!
//! Registry rule: every op file declares `pub const OPS: &[&str]`, the names its ops return from
//! [`Op::name`](crate::Op::name), and its `#[cfg(test)]` module holds a gradient check (through
//! [`crate::check`]) for each of them. The registry test below fails when a name returned by
//! any `fn name` in an op file is missing from that file's `OPS`, and `tests` in each file fail
//! when a check fails.

pub mod broadcast;
pub mod channel;
pub mod conv;
pub mod elementwise;
pub mod fourier;
pub mod grid_sample;
pub mod loss;
pub mod matmul;
pub mod pool;
pub mod reduce;
