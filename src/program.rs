//! The `colorvision` program as a function of the library, so that a binary of one's own can
//! register its learning rules (`cortex::rule::register`) and then be the whole program: the
//! same subcommands, `--config` files that name its rules, sweeps that run it for every job.
//!
//! ```no_run
//! // in the binary's `main`: `cortex::rule::register(…)` for each rule of its own, then
//! colorvision::program::main();
//! ```

use crate::cli::{Cli, Command, RunOptions};
use crate::commands;
use clap::Parser;

/// Parses the command line and runs the command; on an error, prints it and exits with its
/// status.
pub fn main() {
    crate::interrupt::default_sigpipe();
    let cli = Cli::parse();
    if let Err(e) = crate::interrupt::install_fault_injection() {
        eprintln!("colorvision: error: {e}");
        std::process::exit(2);
    }
    let command = cli.command.unwrap_or(Command::Run(RunOptions {
        common: cli.common,
        continue_from: None,
    }));
    let result = match &command {
        Command::Run(o) => commands::run(o),
        Command::Simulate(o) => commands::simulate(o),
        Command::Train(o) => commands::train(o),
        Command::Gamut(o) => commands::gamut(o),
        Command::CmfSim(o) => commands::cmf_sim(o),
        Command::Scope(o) => commands::scope(o),
        Command::Convergence(o) => commands::convergence(o),
        Command::WDcGauge(o) => crate::w_gauge::w_dc_gauge(&o.run, o.steps).map(|_| ()),
        Command::StilesBurch(o) => crate::stiles_burch::command(o).map(|_| ()),
        Command::Average(o) => crate::averaging::command(o),
        Command::PerceptAlignment(o) => {
            crate::percept_alignment::command(&o.run, &o.against, o.batches).map(|_| ())
        }
        Command::Experiment(o) => commands::experiment(o),
        Command::Resume(o) => commands::resume(o),
        Command::Sweep(o) => commands::sweep(o),
        Command::Gather(o) => commands::gather(o),
    };
    crate::interrupt::stand_down();
    if let Err(e) = result {
        // A long value the user gave is named, not echoed whole.
        let said = science::config::shortened(&e.to_string());
        eprintln!("colorvision: error: {said}");
        std::process::exit(e.exit_code());
    }
}
