//! The `rigid` binary: parse the command line, run the library, print errors, exit with the
//! codes of docs/cli.md (0 success, 2 bad input, 1 any other failure).

use clap::Parser;
use rigid_sandbox::cli::args::{Command, RunArgs};
use rigid_sandbox::cli::{AppError, execute};
use rigid_sandbox::error::SceneError;
use std::io::IsTerminal;

fn main() {
    let cli = rigid_sandbox::cli::args::Cli::parse();
    if let Err(e) = execute(cli.command.unwrap_or_else(|| Command::Run(RunArgs::default()))) {
        let code = e.exit_code();
        if matches!(e, AppError::OutputClosed) {
            std::process::exit(code); // a reader that stopped reading: nothing to say
        }
        eprintln!("error: {e}");
        // On a terminal, also show the offending line of a RON error (miette's snippet), under
        // a short heading: the message itself was printed just above.
        if let AppError::Scene(SceneError::Parse { text, at, path, line, col, .. }) = e
            && std::io::stderr().is_terminal()
        {
            let place = format!("at {}:{line}:{col}", path.display());
            eprintln!("{:?}", miette::Report::new(Snippet { place, text, at }));
        }
        std::process::exit(code);
    }
}

/// The snippet of a scene error: where, and the line with a caret.
#[derive(Debug, thiserror::Error, miette::Diagnostic)]
#[error("{place}")]
struct Snippet {
    place: String,
    #[source_code]
    text: miette::NamedSource<String>,
    #[label("here")]
    at: miette::SourceSpan,
}
