//! # colorvision
//!
//! The wiring of the experiment: the retina (`retina`) produces optic nerve signals, the cortex
//! (`cortex`) learns from them alone, and CMF-SIM (`colorimetry`) measures the colour
//! dimensionality that emerges. This crate implements the black-box observer CMF-SIM probes
//! (retina + learned cortex), the command line, and the run folders.

pub mod alignment_plot;
pub mod averaging;
pub mod cli;
pub mod commands;
pub mod config;
pub mod convergence;
pub mod experiments;
pub mod gamut;
pub mod gather;
pub mod interrupt;
pub mod invariants;
pub mod io;
pub mod ladder;
pub mod measurement_dir;
pub mod observer;
pub mod paper;
pub mod pictures;
pub mod program;
pub mod report;
pub mod run;
pub mod run_error;
pub mod run_folder;
pub mod run_lock;
pub mod source;
pub mod stats;
pub mod stiles_burch;
pub mod sweep;
pub mod w_gauge;
