//! Command-line shell: parses arguments (clap), calls the library, formats output.
//! Every subcommand lives in its own file; errors end the process with a one-line reason
//! on stderr and a non-zero exit code.

mod ims;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// rockwatch: seismic monitoring of precariously balanced rocks and other freestanding blocks.
#[derive(Debug, Parser)]
#[command(name = "rockwatch", version, about, long_about = None, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Intensity measures of a record (PGA, PGV, CAV, Arias, durations, SA, ASI/SI/VSI, …).
    Ims(ims::ImsArgs),
}

/// Parses the command line, runs the subcommand, and maps errors to a one-line message.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    let result: anyhow::Result<()> = match cli.command {
        Command::Ims(args) => ims::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("rockwatch: error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
