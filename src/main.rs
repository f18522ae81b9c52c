//! `colorvision`: see `colorvision --help`.

use clap::Parser;
use colorvision::cli::{Cli, Command, RunOptions};
use colorvision::commands;

fn main() {
    colorvision::interrupt::default_sigpipe();
    let cli = Cli::parse();
    if let Err(e) = colorvision::interrupt::install_fault_injection() {
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
        Command::WDcGauge(o) => colorvision::w_gauge::w_dc_gauge(&o.run, o.steps).map(|_| ()),
        Command::StilesBurch(o) => colorvision::stiles_burch::command(o).map(|_| ()),
        Command::Average(o) => colorvision::averaging::command(o),
        Command::Experiment(o) => commands::experiment(o),
        Command::Resume(o) => commands::resume(o),
        Command::Sweep(o) => commands::sweep(o),
        Command::Gather(o) => commands::gather(o),
    };
    if let Err(e) = result {
        eprintln!("colorvision: error: {e}");
        std::process::exit(e.exit_code());
    }
}
