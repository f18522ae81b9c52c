//! A fourth cone class, measured before any cortex is trained on it: how much of Q's signal
//! is its own in the scenes an eye sees, and how that compares with the eye's noise and with
//! the error of telling, at a Q cone, what L, M and S would have caught there (the gates a
//! training arm must pass; evaluation only, reading the scenes' true excitations).
//!
//! - [`own_signal`]: the share of Q's variance that an affine least-squares fit from L, M and S
//!   leaves, within each tile and across tiles, on held-out samples.
//! - [`gates`]: that share through a real eye (its mosaic, sampling, noise and lateral
//!   inhibition), beside the photon and LI noise at the Q cones and the demosaicking error, one
//!   table row per eye × cone set × scenes × white balance.

pub mod gates;
pub mod own_signal;
