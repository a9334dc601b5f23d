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
mod fragility;
mod geometry;
mod hazard;
mod ims;
mod monitor;
mod mseed_flags;
mod node;
mod pulses;
mod replay;
mod report;
mod rock_flags;
mod simulate;
mod stations;
mod status;
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
    /// Log filter: a level (error, warn, info, debug, trace, off) or target=level pairs
    /// (`rockwatch=debug,rustdds=warn`). Wins over RUST_LOG and ROCKWATCH_LOG; default:
    /// rockwatch's lines from info up, the libraries' (RustDDS, iceoryx2) errors.
    #[arg(long = "log-level", global = true, value_name = "FILTER")]
    log_level: Option<String>,
    /// Log lines on stderr: `text` for people, `json` for log shippers (one object per
    /// line: timestamp, level, target, fields).
    #[arg(long = "log-format", global = true, value_enum, default_value_t = rockwatch::logging::LogFormat::Text)]
    log_format: rockwatch::logging::LogFormat,
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
    /// Draw an event report (a rock's fall or episode end) again from a state directory.
    Report(report::ReportArgs),
    /// What stands now: every rock and station of a running node (its web API) or of a
    /// state directory; exit 1 when a rock is fallen or a station stale, 2 on error.
    Status(status::StatusArgs),
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
    /// Overturning fragility of one rock from a suite of records (multiple-stripe analysis,
    /// maximum likelihood, bootstrap intervals, two-IM surface).
    Fragility(fragility::FragilityArgs),
    /// A rock's volume, centre of mass, resting contact and planar body (b₊, b₋, h, ρ, α±)
    /// per toppling direction from its closed mesh (OBJ, PLY, STL).
    Geometry(geometry::GeometryArgs),
}

/// The level of `--ros-args --log-level LEVEL` (or `--log-level rockwatch:=LEVEL`, the
/// node's logger, also under its `__node` name); another logger's name is an error.
fn ros_log_level() -> anyhow::Result<Option<log::LevelFilter>> {
    let ros = ros_args();
    let node = ros
        .node_names
        .last()
        .map_or(rockwatch::ros2::NODE_NAME, |(_, n)| n.as_str());
    let mut level = ros.log_level.map(|l| l.filter());
    for (logger, l) in &ros.logger_levels {
        if logger != rockwatch::ros2::NODE_NAME && logger != node {
            anyhow::bail!(
                "--ros-args --log-level {logger}:=…: rockwatch has no logger {logger:?} (its logger is {node:?}; or give the level alone)"
            );
        }
        level = Some(l.filter());
    }
    Ok(level)
}

/// Output format for people (`text`) or programs (`json`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum OutputFormat {
    /// A readable summary or table with units.
    Text,
    /// One JSON object, SI units.
    Json,
}

/// The process's `--ros-args` (empty without them), parsed once before the subcommand runs.
static ROS_ARGS: std::sync::OnceLock<rockwatch::ros2::RosArgs> = std::sync::OnceLock::new();

/// The `--ros-args` of the command line (the ROS 2 commands read them).
pub fn ros_args() -> &'static rockwatch::ros2::RosArgs {
    ROS_ARGS.get_or_init(rockwatch::ros2::RosArgs::default)
}

/// Applies the `--ros-args` naming rules (`__ns`, `__node`, remaps) to a `[ros2]` section:
/// what the node and every client (replay, reset, acquire, the demo) use.
pub fn apply_ros_naming(config: &mut rockwatch::ros2::Ros2Config) {
    ros_args().apply_naming(config);
}

/// The help of the ROS 2 commands' `--ros-args`.
const ROS_ARGS_HELP: &str =
    "ROS 2 arguments, after the options: --ros-args … [--], as every ROS 2 \
    node takes them (rcl's rules): -r __ns:=/NS (namespace), -r __node:=NAME, -r from:=to \
    (remap), -p name:=value, --params-file FILE, --log-level LEVEL, -e/--enclave NAME \
    (README, \"ROS 2 names, --ros-args and parameters\")";

/// The subcommands that take `--ros-args` (they join the ROS 2 graph).
const ROS_COMMANDS: [&str; 5] = ["node", "replay", "reset", "acquire", "demo"];

/// Parses the command line, runs the subcommand, and maps errors to a one-line message.
pub fn run() -> ExitCode {
    // `--ros-args … [--]` sections are ROS 2's (rcl's rules), the rest is ours.
    let argv: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let (own, ros, ros_seen) = rockwatch::ros2::split_ros_args(&argv);
    if ros_seen {
        let ros: Vec<String> = ros
            .iter()
            .map(|a| a.to_string_lossy().into_owned())
            .collect();
        let command = own.get(1).map(|c| c.to_string_lossy().into_owned());
        if !command
            .as_deref()
            .is_some_and(|c| ROS_COMMANDS.contains(&c))
        {
            eprintln!(
                "rockwatch: error: --ros-args is taken by the ROS 2 commands only ({}), not by {}",
                ROS_COMMANDS.join(", "),
                command.as_deref().unwrap_or("rockwatch without a command")
            );
            return ExitCode::FAILURE;
        }
        match rockwatch::ros2::RosArgs::parse(&ros) {
            Ok(parsed) => {
                let _ = ROS_ARGS.set(parsed);
            }
            Err(e) => {
                eprintln!("rockwatch: error: {e:#}");
                return ExitCode::FAILURE;
            }
        }
    }
    // Negative numbers are values, not flags, in every subcommand (`--scale -1`). The ROS 2
    // commands' `--ros-args` are split off above, before clap: their help says so (the README
    // promises every flag in `rockwatch <command> --help`; tests/doc_commands.rs checks it).
    let command = Cli::command().mut_subcommands(|c| {
        let ros = ROS_COMMANDS.contains(&c.get_name());
        let c = c.allow_negative_numbers(true);
        if ros {
            c.after_help(ROS_ARGS_HELP)
        } else {
            c
        }
    });
    let is_status = own.get(1).is_some_and(|c| c == "status");
    let parsed = command
        .try_get_matches_from(own)
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
            // `status`'s errors are 2 (1 is its alarm).
            if is_status {
                return ExitCode::from(status::EXIT_ERROR);
            }
            return ExitCode::FAILURE;
        }
    };
    // rockwatch's records and the libraries' (RustDDS and iceoryx2 through `log`, ros2-client
    // through `tracing`) on stderr. `--log-level` wins over `--ros-args --log-level`.
    let ros_level = match ros_log_level() {
        Ok(level) => level,
        Err(e) => {
            eprintln!("rockwatch: error: {e:#}");
            return ExitCode::FAILURE;
        }
    };
    let log = rockwatch::logging::LogOptions {
        level: cli
            .log_level
            .clone()
            .or_else(|| ros_level.map(|l| l.as_str().to_ascii_lowercase()))
            .or_else(|| {
                matches!(cli.command, Command::Demo(_))
                    .then(|| rockwatch::logging::DEMO_FILTER.to_string())
            }),
        format: cli.log_format,
    };
    // The long-running services never wait for stderr (a stuck reader must not stall them).
    let service = matches!(cli.command, Command::Node(_) | Command::Acquire(_));
    let installed = if service {
        rockwatch::logging::init_queued(&log)
    } else {
        rockwatch::logging::init(&log)
    };
    if let Err(e) = installed {
        eprintln!("rockwatch: error: {e}");
        return ExitCode::FAILURE;
    }
    if let Err(e) = rockwatch::signals::report_bus_errors() {
        eprintln!("rockwatch: error: {e:#}");
        return ExitCode::FAILURE;
    }
    // `status` is a monitoring check: its own exit codes (0 OK, 1 alarm, 2 error).
    let cli = match cli.command {
        Command::Status(args) => {
            let code = status::run(args);
            rockwatch::logging::flush(std::time::Duration::from_secs(2));
            return code;
        }
        _ => cli,
    };
    let result = match cli.command {
        Command::Acquire(args) => acquire::run(args),
        Command::Alerts(args) => alerts::run_alerts(args),
        Command::Reset(args) => alerts::run_reset(args),
        Command::Demo(args) => demo::run(args),
        Command::Monitor(args) => monitor::run(args),
        Command::Report(args) => report::run(args),
        Command::Node(args) => node::run(args),
        Command::Replay(args) => replay::run(args),
        Command::Simulate(args) => simulate::run(args),
        Command::Pulses(args) => pulses::run(args),
        Command::Ims(args) => ims::run(args),
        Command::Stations(args) => stations::run(args),
        Command::Study(args) => study::run(args),
        Command::Hazard(args) => hazard::run(args),
        Command::Fragility(args) => fragility::run(args),
        Command::Geometry(args) => geometry::run(args),
        Command::Status(_) => Ok(()), // run above
    };
    // The queued records first (bounded: a stderr nobody reads cannot hold the exit).
    rockwatch::logging::flush(std::time::Duration::from_secs(2));
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("rockwatch: error: {error:#}");
            ExitCode::FAILURE
        }
    }
}
