//! # colorvision
//!
//! The command line and the run folders on top of the measurement library (`science`): the
//! retina (`retina`) produces optic nerve signals, the cortex (`cortex`) learns from them alone,
//! and CMF-SIM (`colorimetry`) measures, through the observer `science` builds, the colour
//! dimensionality that emerges. This crate trains runs into folders ([`run`]), runs the paper's
//! experiments ([`experiments`]), sweeps ([`sweep`]), gathers recorded runs into tables
//! ([`gather`]) and writes pictures and reports.

pub mod alignment_plot;
pub mod averaging;
pub mod cli;
pub mod commands;
pub mod convergence;
pub mod experiments;
pub mod gather;
pub mod instruction_set;
pub mod interrupt;
pub mod io;
pub mod percept_alignment;
pub mod pictures;
pub mod program;
pub mod report;
pub mod run;
pub mod scene_bar;
pub mod stiles_burch;
pub mod sweep;
pub mod w_gauge;
