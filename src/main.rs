use clap::Parser;
use colorvision::cli::{Cli, Command};

fn main() {
    let cli = Cli::parse();
    let command = cli.command.unwrap_or(Command::Run(cli.common));
    println!("colorvision: {command:?} (being wired)");
}
