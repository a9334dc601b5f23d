//! Command-line shell: parses arguments (clap), calls the library, formats output.
//! Every subcommand lives in its own file; errors end the process with a one-line reason
//! on stderr and a non-zero exit code.

use clap::{CommandFactory, FromArgMatches, Parser, Subcommand, ValueEnum};
use std::process::ExitCode;

/// `println!` for command output: a closed pipe (`rockwatch … | head`) ends the process
/// quietly with status 0 instead of panicking; any other write error is a one-line error.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = writeln!(std::io::stdout().lock(), $($arg)*) {
            $crate::cli::stdout_failed(e);
        }
    }};
}

/// `print!` counterpart of [`outln!`].
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if let Err(e) = write!(std::io::stdout().lock(), $($arg)*) {
            $crate::cli::stdout_failed(e);
        }
    }};
}

/// Ends the process after a failed write to stdout.
pub fn stdout_failed(error: std::io::Error) -> ! {
    if error.kind() == std::io::ErrorKind::BrokenPipe {
        std::process::exit(0);
    }
    eprintln!("rockwatch: error: cannot write to stdout: {error}");
    std::process::exit(1);
}

mod acquire;
mod alerts;
mod demo;
mod geometry;
mod hazard;
mod ims;
mod monitor;
mod node;
mod pulses;
mod replay;
mod simulate;
mod stations;
mod study;

/// rockwatch: seismic monitoring of precariously balanced rocks and other freestanding blocks.
#[derive(Debug, Parser)]
#[command(
    name = "rockwatch",
    version,
    about,
    long_about = None,
    propagate_version = true,
    allow_negative_numbers = true
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Acquire stations from a SeedLink server (StationXML calibration) and publish them to
    /// the node.
    Acquire(acquire::AcquireArgs),
    /// List the alert history of a state directory.
    Alerts(alerts::AlertsArgs),
    // No doc comment here: a variant's doc comment replaces the long help, and `reset --help`
    // shows ResetArgs' (its first line is the summary in this list).
    Reset(alerts::ResetArgs),
    /// Intensity measures of a record (PGA, PGV, CAV, Arias, durations, SA, ASI/SI/VSI, …).
    Ims(ims::ImsArgs),
    /// Run the built-in demonstration on a bundled earthquake record (no arguments needed).
    Demo(demo::DemoArgs),
    /// Run the monitoring engine over a record: which catalogued blocks move or fall.
    Monitor(monitor::MonitorArgs),
    /// Run the live node: ROS 2 input (/pbr/accel, Imu topics), engine, /pbr/ims, /pbr/state
    /// and /pbr/alerts.
    Node(node::NodeArgs),
    /// Replay a record or a synthetic pulse to a running node as live packets.
    Replay(replay::ReplayArgs),
    /// Simulate one rigid block under a ground-motion record.
    Simulate(simulate::SimulateArgs),
    /// Generate synthetic near-fault pulses (Mavroeidis & Papageorgiou 2003) and write one
    /// record file per pulse.
    Pulses(pulses::PulsesArgs),
    /// Show StationXML channel epochs and whether each is usable (gain, orientation, units).
    Stations(stations::StationsArgs),
    /// Reproduce and extend the seed paper's intensity-measure study (efficiency and
    /// sufficiency of 37 IMs for sliding and rocking blocks, vector IMs, fragility).
    Study(study::StudyArgs),
    /// Annual overturning rate, return period and survival probability of one rock from its
    /// fragility and its site's hazard curve (OpenQuake or two-column CSV).
    Hazard(hazard::HazardArgs),
    /// A rock's volume, centre of mass, resting contact and planar body (b₊, b₋, h, ρ, α±)
    /// per toppling direction from its closed mesh (OBJ, PLY, STL).
    Geometry(geometry::GeometryArgs),
}

/// Output format for people (`text`) or programs (`json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// A readable summary or table with units.
    Text,
    /// One JSON object, SI units.
    Json,
}

/// Parses the command line, runs the subcommand, and maps errors to a one-line message.
pub fn run() -> ExitCode {
    // Negative numbers are values, not flags, in every subcommand (`--scale -1`).
    let command = Cli::command().mut_subcommands(|c| c.allow_negative_numbers(true));
    let parsed = command
        .try_get_matches()
        .and_then(|matches| Cli::from_arg_matches(&matches));
    let cli = match parsed {
        Ok(cli) => cli,
        // --help and --version print their text and succeed.
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        // A usage error: one line naming the problem, then where to look.
        Err(e) => {
            // clap's message up to its usage block, folded onto one line.
            let text = e.render().to_string();
            let reason: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(|l| l.trim().trim_start_matches("error: "))
                .collect();
            eprintln!(
                "rockwatch: error: {} (see rockwatch --help)",
                reason.join(" ")
            );
            return ExitCode::FAILURE;
        }
    };
    // RustDDS and ros2-client log through the `log` facade: their errors reach stderr.
    rockwatch::stderr_log::init();
    let result = match cli.command {
        Command::Acquire(args) => acquire::run(args),
        Command::Alerts(args) => alerts::run_alerts(args),
        Command::Reset(args) => alerts::run_reset(args),
        Command::Demo(args) => demo::run(args),
        Command::Monitor(args) => monitor::run(args),
        Command::Node(args) => node::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Pulses(args) => pulses::run(args),
        Command::Ims(args) => ims::run(args),
        Command::Stations(args) => stations::run(args),
        Command::Study(args) => study::run(args),
        Command::Hazard(args) => hazard::run(args),
        Command::Geometry(args) => geometry::run(args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("rockwatch: error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
