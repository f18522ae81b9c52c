//! # autodiff — a reverse-mode tape over faer
//!
//! The learning machinery of colorvision, built so researchers can read it, write their own ops
//! and swap the learning rule.
//!
//! ## Conventions
//! - **Values.** A [`Tensor`] is dense and row-major (last axis fastest), rank 0–6. Images are
//!   `(batch, channels, height, width)`. Complex arrays carry a trailing axis of length 2
//!   (real, imaginary).
//! - **Scalars.** A [`Tape`] is generic over [`Float`]: `f32` for training, `f64` for gradient
//!   checks ([`check`]). GEMM runs on faer for both.
//! - **Gradients.** `backward` computes `∂L/∂x` (the direction of *increase*); optimisers
//!   subtract it. Op backwards *add* into their input slots.
//! - **Errors.** A shape mismatch while recording is a programming error and panics, naming the
//!   op and both shapes. I/O (safetensors) returns [`params::SafetensorsError`].
//! - **Memory.** [`Tape::clear`] recycles every buffer into a pool keyed by length; a training
//!   loop with fixed shapes allocates no tensor buffers after its first step. Tensors from the
//!   pool start on a 64-byte boundary (a cache line; kernels don't assume it, they are faster
//!   with it).

pub mod check;
pub mod float;
pub mod gemm;
pub mod learn;
pub mod nn;
pub mod op;
pub mod ops;
pub mod optim;
pub mod params;
pub mod pool;
pub mod profile;
pub mod scopes;
pub mod tape;
pub mod tensor;

pub use float::Float;
pub use op::{BackwardCx, GradSlots, GradTarget, Op, Pointwise};
pub use params::{ParamId, ParamStore};
pub use pool::BufferPool;
pub use tape::{BackwardHooks, NoHooks, NodeKind, NodeView, NonFiniteSite, Pass, Tape, Var};
pub use tensor::{Shape, Tensor};
