//! The `rigid` binary: parse the command line, run the library, print errors, exit with the
//! codes of CONTRACTS.md §3 (0 success, 2 bad input, 1 any other failure).

use clap::Parser;
use rigid_sandbox::cli::args::{Command, RunArgs};
use rigid_sandbox::cli::{AppError, execute};
use rigid_sandbox::error::SceneError;
use std::io::IsTerminal;

fn main() {
    let cli = rigid_sandbox::cli::args::Cli::parse();
    if let Err(e) = execute(cli.command.unwrap_or_else(|| Command::Run(RunArgs::default()))) {
        let code = e.exit_code();
        eprintln!("error: {e}");
        // On a terminal, also show the offending line of a RON error (miette's snippet).
        if let AppError::Scene(parse @ SceneError::Parse { .. }) = e
            && std::io::stderr().is_terminal()
        {
            eprintln!("{:?}", miette::Report::new(parse));
        }
        std::process::exit(code);
    }
}
