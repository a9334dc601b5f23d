//! The tests' optional peers, installed by `.ci/run`: ObsPy (`pip install obspy`), Cyclone
//! DDS's Python binding, the colcon build of `msg/` (pbr_msgs). A missing peer skips a test
//! locally and fails it under CI.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::fixtures::repo;

/// Runs `python3 -c script args…` and returns its standard output; `None` (with a printed
/// reason) when python3 or ObsPy is missing — except under CI (`CI` set), where a missing peer
/// fails the test instead of skipping it. A failing script fails the test with its stderr.
pub fn run_obspy(script: &str, args: &[&str]) -> Option<Vec<u8>> {
    let output = match Command::new("python3")
        .arg("-c")
        .arg(script)
        .args(args)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            let reason = format!("python3 not available ({e}); install it and `pip install obspy`");
            assert!(std::env::var_os("CI").is_none(), "{reason}");
            println!("SKIPPED: {reason}");
            return None;
        }
    };
    let stderr = String::from_utf8_lossy(&output.stderr);
    if !output.status.success() && stderr.contains("No module named 'obspy'") {
        let reason = "ObsPy not importable; run `pip install obspy`";
        assert!(std::env::var_os("CI").is_none(), "{reason}");
        println!("SKIPPED: {reason}");
        return None;
    }
    assert!(output.status.success(), "ObsPy failed: {stderr}");
    Some(output.stdout)
}

/// True if `python3` can import Cyclone DDS's Python binding (`cyclonedds`, pinned in .ci/run).
pub fn have_cyclonedds() -> bool {
    Command::new("python3")
        .args(["-c", "import cyclonedds.domain"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// Whether an optional peer of a test is `available`: true if so. If not, the test is skipped
/// locally (prints `skipped: <what> not found`, returns false) but FAILS under `CI=true`, where
/// .ci/run installs it (`how` says how).
pub fn peer_available(available: bool, what: &str, how: &str) -> bool {
    if !available {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but {what} is missing ({how})"
        );
        eprintln!("skipped: {what} not found ({how})");
    }
    available
}

/// The environment variable naming the colcon install base (merged layout) of `msg/`, the
/// ROS 2 package `pbr_msgs` built by `launch-scripts/build-msgs.sh` (.ci/run sets it).
pub const PBR_MSGS_PREFIX_ENV: &str = "ROCKWATCH_PBR_MSGS_PREFIX";

/// The colcon install of `pbr_msgs` whose generated Python types (the messages and the service
/// `ResetPbr`: an install built before the service counts as none) import (with rclpy) once
/// its `local_setup.sh` is sourced: `$ROCKWATCH_PBR_MSGS_PREFIX`, else `target/pbr_msgs` (the
/// script's default). None (test skipped) if there is none, except under `CI=true` (panics).
pub fn pbr_msgs_install() -> Option<PathBuf> {
    let prefix = std::env::var_os(PBR_MSGS_PREFIX_ENV)
        .map_or_else(|| repo().join("target/pbr_msgs"), PathBuf::from);
    let ok = prefix.join("local_setup.sh").is_file()
        && Command::new("sh")
            .arg("-c")
            .arg(format!(
                "{}; exec python3 -c 'import rclpy; from pbr_msgs.msg import PbrAlert, AccelPacket; from pbr_msgs.srv import ResetPbr'",
                source_pbr_msgs(&prefix)
            ))
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .status()
            .is_ok_and(|s| s.success());
    let what = format!(
        "the colcon build of msg/ with importable Python types in {}",
        prefix.display()
    );
    peer_available(
        ok,
        &what,
        &format!("run launch-scripts/build-msgs.sh, or set {PBR_MSGS_PREFIX_ENV}"),
    )
    .then_some(prefix)
}

/// Shell (sh) commands setting up the environment of the colcon install at `prefix` as its
/// own setup file does (AMENT_PREFIX_PATH, CMAKE_PREFIX_PATH, PYTHONPATH, LD_LIBRARY_PATH),
/// wherever the install lies (COLCON_CURRENT_PREFIX). The setup file is not `set -e` clean.
pub fn source_pbr_msgs(prefix: &Path) -> String {
    format!(
        "set +e; COLCON_CURRENT_PREFIX='{p}'; . '{p}/local_setup.sh'; unset COLCON_CURRENT_PREFIX; set -e",
        p = prefix.display()
    )
}
