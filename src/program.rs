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
use clap::parser::ValueSource;
use clap::{ArgMatches, CommandFactory, FromArgMatches};

/// Parses the command line and runs the command; on an error, prints it and exits with its
/// status.
pub fn main() {
    crate::interrupt::default_sigpipe();
    let matches = Cli::command().get_matches();
    if let Some(message) = options_before_subcommand(&matches) {
        eprintln!("colorvision: error: {message}");
        std::process::exit(2);
    }
    let cli = Cli::from_arg_matches(&matches).unwrap_or_else(|e| e.exit());
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

/// The error for options given before a subcommand (`colorvision --steps 4 train`): they belong
/// to the default `run` and the subcommand would not see them, so the line is refused, naming
/// them, and saying which the subcommand does not take at all. `None` when there is no
/// subcommand or nothing precedes it.
pub fn options_before_subcommand(matches: &ArgMatches) -> Option<String> {
    let sub = matches.subcommand_name()?;
    let cli = Cli::command();
    let given: Vec<&str> = matches
        .ids()
        .filter(|id| matches.value_source(id.as_str()) == Some(ValueSource::CommandLine))
        .filter_map(|id| cli.get_arguments().find(|a| a.get_id() == id))
        .filter_map(|a| a.get_long())
        .collect();
    if given.is_empty() {
        return None;
    }
    let takes = |long: &str| {
        cli.find_subcommand(sub)
            .is_some_and(|s| s.get_arguments().any(|a| a.get_long() == Some(long)))
    };
    let flags = |names: &[&str]| {
        names
            .iter()
            .map(|l| format!("--{l}"))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let lacks: Vec<&str> = given.iter().copied().filter(|l| !takes(l)).collect();
    let advice = if lacks.is_empty() {
        format!("give them after it (`colorvision {sub} --{} …`)", given[0])
    } else {
        format!("`{sub}` takes no {}", flags(&lacks))
    };
    Some(format!(
        "{} given before the subcommand `{sub}`, which would not see them: {advice}",
        flags(&given)
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(line: &[&str]) -> ArgMatches {
        Cli::command()
            .try_get_matches_from(line)
            .expect("a line clap accepts")
    }

    #[test]
    fn options_before_a_subcommand_are_refused_and_named() {
        let said = options_before_subcommand(&parse(&[
            "colorvision",
            "--preset",
            "tiny",
            "--steps",
            "4",
            "train",
        ]))
        .expect("options before `train` are refused");
        assert!(
            said.contains("--preset") && said.contains("--steps") && said.contains("`train`"),
            "{said}"
        );
        assert!(said.contains("give them after it"), "{said}");
        let said =
            options_before_subcommand(&parse(&["colorvision", "--cones", "LM", "gather", "runs"]))
                .expect("an option before `gather` is refused");
        assert!(said.contains("`gather` takes no --cones"), "{said}");
    }

    #[test]
    fn options_after_the_subcommand_or_without_one_are_accepted() {
        for line in [
            &["colorvision", "train", "--preset", "tiny", "--steps", "4"][..],
            &["colorvision", "--preset", "tiny", "--steps", "4"],
            &["colorvision", "resume", "runs/x", "--steps", "8"],
            &["colorvision"],
        ] {
            assert_eq!(options_before_subcommand(&parse(line)), None, "{line:?}");
        }
    }
}
