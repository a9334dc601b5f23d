//! Refusals, end to end through the binary (issue 11): bounded work on bad input (finding 7)
//! — every command given input that would make it run forever, allocate gigabytes or panic
//! refuses it with one line `rockwatch: error: …` and exit 1, quickly — and one node per
//! state directory (finding 4).
//!
//! Each command runs under a deadline ([`DEADLINE`]): a regression that hangs or allocates
//! its way through fails the test instead of hanging CI.

use std::path::{Path, PathBuf};
use std::time::Duration;

use rockwatch_test_harness::process::Ran;
use rockwatch_test_harness::rockwatch_bin;

/// Longest a refused command may take. The refusals are immediate (reading a 2000-sample
/// record); 30 s leaves room for a loaded CI machine while a hang (the bugs took hours or
/// never ended) or a multi-GB allocation is still caught.
const DEADLINE: Duration = Duration::from_secs(30);

const RINALDI: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../../tests/data/records/Rinaldi228.AT2"
);
const NODE_TOML: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/node.toml");
const CATALOGUE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../../config/catalogue.toml");

/// Runs rockwatch with `args` under this file's bounds: killed, and the test failed, past
/// [`DEADLINE`]; memory capped at 2 GB, so a runaway allocation aborts instead of swapping the
/// machine; no DDS traffic beyond this host should a refusal regress into starting the node.
fn bounded(args: &[&str]) -> Ran {
    rockwatch_bin!()
        .run(args)
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        .deadline(DEADLINE)
        .memory_limit_kib(2_000_000)
        .text()
}

/// The command failed with exit 1 and one line `rockwatch: error: …` containing `needle`.
fn refused(run: &Ran, needle: &str) {
    assert_eq!(
        run.code,
        Some(1),
        "exit {:?}\nstdout: {}\nstderr: {}",
        run.code,
        run.stdout,
        run.stderr
    );
    let errors: Vec<&str> = run
        .stderr
        .lines()
        .filter(|l| l.starts_with("rockwatch: error: "))
        .collect();
    assert_eq!(errors.len(), 1, "stderr: {}", run.stderr);
    assert!(
        !run.stderr.contains("panicked") && errors[0].contains(needle),
        "expected {needle:?} in: {}",
        run.stderr
    );
}

/// Rinaldi228.AT2 with its `DT` replaced by `dt` (a text substitution in the NPTS/DT line).
fn rinaldi_with_dt(dir: &Path, dt: &str) -> PathBuf {
    let text = std::fs::read_to_string(RINALDI).unwrap();
    let text = text.replacen("DT=   .0100 SEC", &format!("DT= {dt} SEC"), 1);
    assert!(text.contains(&format!("DT= {dt} SEC")));
    let path = dir.join("tiny-dt.AT2");
    std::fs::write(&path, text).unwrap();
    path
}

fn block_args() -> Vec<&'static str> {
    vec![
        "--width", "1", "--height", "2", "--mu-s", "0.6", "--mu-k", "0.5",
    ]
}

#[test]
fn simulate_refuses_a_nanosecond_sampling_interval() {
    let dir = tempfile::tempdir().unwrap();
    let record = rinaldi_with_dt(dir.path(), "1e-9");
    let mut args = vec!["simulate", "--record", record.to_str().unwrap()];
    args.extend(block_args());
    refused(&bounded(&args), "sampling interval 1e-9 s is outside");
}

#[test]
fn simulate_refuses_a_billion_seconds_of_free_vibration() {
    let mut args = vec!["simulate", "--record", RINALDI, "--t-extra", "1e9"];
    args.extend(block_args());
    refused(&bounded(&args), "integration steps");
}

#[test]
fn simulate_refuses_accelerations_of_1e306() {
    let dir = tempfile::tempdir().unwrap();
    let csv = dir.path().join("huge.csv");
    let mut text = String::from("t,ax\n");
    for i in 0..200 {
        let a = if i % 2 == 0 { "1e306" } else { "-1e306" };
        text.push_str(&format!("{},{a}\n", f64::from(i) * 0.01));
    }
    std::fs::write(&csv, text).unwrap();
    let mut args = vec!["simulate", "--record", csv.to_str().unwrap()];
    args.extend(block_args());
    refused(&bounded(&args), "beyond ±980.665 m/s² (100 g)");
    // Scaling a plausible record beyond the bound is refused too.
    let mut args = vec!["simulate", "--record", RINALDI, "--scale", "1e300"];
    args.extend(block_args());
    refused(&bounded(&args), "scaled by 1e300");
}

#[test]
fn ims_refuses_a_nanosecond_sampling_interval() {
    let dir = tempfile::tempdir().unwrap();
    let record = rinaldi_with_dt(dir.path(), "1e-9");
    refused(
        &bounded(&["ims", "--record", record.to_str().unwrap()]),
        "sampling interval",
    );
}

fn monitor_args<'a>(record: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "monitor",
        "--config",
        NODE_TOML,
        "--record",
        record,
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
    ];
    args.extend(extra);
    args
}

#[test]
fn monitor_refuses_a_nanosecond_sampling_interval() {
    let dir = tempfile::tempdir().unwrap();
    let record = rinaldi_with_dt(dir.path(), "1e-9");
    refused(
        &bounded(&monitor_args(record.to_str().unwrap(), &[])),
        "sampling interval",
    );
}

#[test]
fn monitor_refuses_zero_packets_and_negative_or_huge_tails() {
    refused(
        &bounded(&monitor_args(RINALDI, &["--packet-ms", "0"])),
        "--packet-ms must be 1 to 60000",
    );
    refused(
        &bounded(&monitor_args(RINALDI, &["--tail", "-1"])),
        "--tail must be 0",
    );
    // A day of tail at 100 Hz is 8.6 M samples: allowed; at 10 kHz it would not be.
    let dir = tempfile::tempdir().unwrap();
    let fast = rinaldi_with_dt(dir.path(), "1e-4");
    refused(
        &bounded(&monitor_args(fast.to_str().unwrap(), &["--tail", "86400"])),
        "more than 10000000",
    );
    // Packets longer than a packet may hold (100 000 samples): 60 s at 10 kHz.
    refused(
        &bounded(&monitor_args(
            fast.to_str().unwrap(),
            &["--packet-ms", "60000"],
        )),
        "samples, more than the 100000",
    );
}

#[test]
fn monitor_fails_when_every_packet_was_rejected() {
    // A MiniSEED-free way to make every packet invalid: a station gain so large that every
    // sample lands beyond the engine's physical bound (20 g) once converted.
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!(
            "catalogue = {CATALOGUE:?}\n[[station]]\nid = \"CI.RRS.00\"\ngain_mps2_per_count = 1e6\n"
        ),
    )
    .unwrap();
    let run = bounded(&[
        "monitor",
        "--config",
        config.to_str().unwrap(),
        "--record",
        RINALDI,
        "--azimuth",
        "228",
        "--station",
        "CI.RRS.00",
        "--tail",
        "0",
    ]);
    refused(&run, "nothing usable");
}

/// `replay` of Rinaldi228 over iceoryx2 with the node configuration `config`, not waiting.
fn replay_args<'a>(config: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut args = vec![
        "replay",
        "--record",
        RINALDI,
        "--station",
        "CI.RRS.00",
        "--transport",
        "iceoryx2",
        "--config",
        config,
        "--wait-s",
        "0",
    ];
    args.extend(extra);
    args
}

#[test]
fn replay_refuses_zero_packets_and_negative_tails() {
    // Refused before any transport is opened: no node is needed.
    for (flag, value, needle) in [
        ("--packet-ms", "0", "--packet-ms must be 1 to 60000"),
        ("--tail", "-1", "--tail must be 0"),
    ] {
        refused(&bounded(&replay_args(NODE_TOML, &[flag, value])), needle);
    }
}

#[test]
fn node_refuses_absurd_shard_counts() {
    let run = bounded(&[
        "node",
        "--catalogue",
        CATALOGUE,
        "--shards",
        "18446744073709551615",
    ]);
    refused(&run, "--shards must be 0 (one per core) to 256");
}

#[test]
fn a_catalogue_is_refused_as_the_iceoryx2_configuration() {
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("node.toml");
    std::fs::write(
        &config,
        format!("catalogue = {CATALOGUE:?}\n[iceoryx2]\nconfig_file = {CATALOGUE:?}\n"),
    )
    .unwrap();
    let run = bounded(&replay_args(config.to_str().unwrap(), &[]));
    refused(&run, "not an iceoryx2 configuration: top-level key");
}

/// Finding 4: two nodes on one state directory both ran, every alert journaled and published
/// twice. The state directory's lock (held here by the test, as a running node holds it)
/// makes `node` and `monitor` refuse it, before any transport is opened.
#[test]
fn a_second_process_on_a_state_directory_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let state = dir.path().join("state");
    std::fs::create_dir_all(&state).unwrap();
    let lock = std::fs::File::create(state.join(rockwatch::journal::LOCK_FILE)).unwrap();
    lock.try_lock().unwrap();
    let state_arg = state.to_str().unwrap();
    // Refused before its DDS participant exists (issue 24 item 8: it was refused only after
    // creating it): RustDDS logs the participant's construction at trace level.
    let run = bounded(&[
        "node",
        "--catalogue",
        CATALOGUE,
        "--state-dir",
        state_arg,
        "--log-level",
        "rockwatch=info,rustdds=trace",
    ]);
    refused(&run, "in use by another rockwatch process");
    assert!(!run.stderr.contains("DomainParticipant"), "{}", run.stderr);
    let run = bounded(&monitor_args(RINALDI, &["--state-dir", state_arg]));
    refused(&run, "one node per state directory");
    // Released (as when the first node ends, however it ends): the directory is usable.
    drop(lock);
    // A node holding the directory whose lock file was deleted still holds it (issue 24
    // item 8: deleting `state/lock` let a second node in).
    let (held, _, _) = rockwatch::journal::Journal::open(&state).unwrap();
    std::fs::remove_file(state.join(rockwatch::journal::LOCK_FILE)).unwrap();
    let run = bounded(&monitor_args(RINALDI, &["--state-dir", state_arg]));
    refused(&run, "one node per state directory");
    drop(held);
    // Released, the directory still holds a node's journal: `monitor` never writes it (issue
    // 20 item 1), while a directory of its own is accepted.
    let run = bounded(&monitor_args(RINALDI, &["--state-dir", state_arg]));
    refused(&run, "holds or held a node's state");
    let own = dir.path().join("rehearsal");
    let run = bounded(&monitor_args(
        RINALDI,
        &["--state-dir", own.to_str().unwrap()],
    ));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
}

/// Issue 20 item 1: a state directory `rockwatch monitor` wrote (a rehearsal's alerts) is not
/// a node's history: `node` refuses it before its DDS participant exists.
#[test]
fn a_node_refuses_a_state_directory_monitor_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let rehearsal = dir.path().join("rehearsal");
    let rehearsal_arg = rehearsal.to_str().unwrap();
    let run = bounded(&monitor_args(RINALDI, &["--state-dir", rehearsal_arg]));
    assert_eq!(run.code, Some(0), "{}", run.stderr);
    let run = bounded(&[
        "node",
        "--catalogue",
        CATALOGUE,
        "--state-dir",
        rehearsal_arg,
        "--log-level",
        "rockwatch=info,rustdds=trace",
    ]);
    refused(&run, "written by `rockwatch monitor`");
    assert!(!run.stderr.contains("DomainParticipant"), "{}", run.stderr);
}
