//! Network namespaces for the tests that open DDS or servers: every such test runs its
//! processes in a fresh network namespace (`unshare -n`, loopback up, plus a veth pair with an
//! address and a multicast route, so a participant that ignored the loopback restriction would
//! send on it), bounded in time.

use std::process::{Command, Output};

/// Shell prelude creating the namespace's interfaces.
pub const NETNS_SETUP: &str = "ip link set lo up && \
    ip link add rwv0 type veth peer name rwv1 && \
    echo 1 > /proc/sys/net/ipv6/conf/rwv0/disable_ipv6 && echo 1 > /proc/sys/net/ipv6/conf/rwv1/disable_ipv6 && \
    ip addr add 10.213.0.1/24 dev rwv0 && ip link set rwv1 up && ip link set rwv0 up && \
    ip route add 224.0.0.0/4 dev rwv0";

/// Shell snippet printing `VETH_TX=<packets sent on rwv0>` (/proc/net/dev is per namespace;
/// /sys would show the host's).
pub const VETH_TX: &str =
    "echo VETH_TX=$(sed 's/:/ /' /proc/net/dev | awk '$1 == \"rwv0\" {print $11}')";

/// Runs `script` (sh, `set -e`) in a new network namespace with `timeout_s` as a hard bound;
/// whatever it leaves running is killed when it ends.
pub fn run_in_netns(script: &str, timeout_s: u32, envs: &[(&str, String)]) -> Output {
    let mut cmd = Command::new("timeout");
    cmd.arg("-k")
        .arg("5")
        .arg(timeout_s.to_string())
        .arg("unshare")
        .arg("-n")
        .arg("sh")
        .arg("-c")
        // The script in a subshell, then whatever it left running is killed: an orphan (a
        // node started with `&` before a failing command ended the script under `set -e`)
        // would keep the output's pipes open, and `output()` would wait for ever.
        .arg(format!(
            "set -e; {NETNS_SETUP}; rc=0; (\n{script}\n) || rc=$?; {KILL_LEFTOVERS}; exit $rc"
        ))
        .env_remove("ROS_DOMAIN_ID")
        .env_remove("ROS_AUTOMATIC_DISCOVERY_RANGE");
    // DDS Security only where a test asks for it (tests/ros2_security.rs sets these itself).
    for var in [
        "ROS_SECURITY_ENABLE",
        "ROS_SECURITY_KEYSTORE",
        "ROS_SECURITY_ENCLAVE_OVERRIDE",
        "ROS_SECURITY_STRATEGY",
    ] {
        cmd.env_remove(var);
    }
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output()
        .expect("run timeout/unshare (util-linux, coreutils)")
}

/// The standard output and error of `o`, as (lossy) UTF-8.
#[must_use]
pub fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

/// Shell snippet killing (SIGKILL) every process of the current network namespace except
/// the shell itself, each named on stderr (`left running by the test: PID CMDLINE`). Only for
/// the private namespace of [`run_in_netns`]: there, every such process is the test's.
pub const KILL_LEFTOVERS: &str = "me=$(readlink /proc/$$/ns/net); \
    for p in /proc/[0-9]*; do pid=${p#/proc/}; [ \"$pid\" = \"$$\" ] && continue; \
    [ \"$(readlink $p/ns/net 2>/dev/null)\" = \"$me\" ] || continue; \
    echo \"left running by the test: $pid $(tr '\\0' ' ' < $p/cmdline 2>/dev/null)\" >&2; \
    kill -KILL $pid 2>/dev/null || true; done";

/// Set in a test re-executed inside its network namespace.
pub const IN_NETNS: &str = "ROCKWATCH_TEST_IN_NETNS";

/// Runs the test `name` of the current test binary again, alone, in a fresh network
/// namespace (see [`run_in_netns`]) with `ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST`, bounded by
/// `timeout_s`. Returns true inside the namespace (run the body there); in the caller, asserts
/// that the re-executed test passed and returns false.
pub fn reexec_in_netns(name: &str, timeout_s: u32) -> bool {
    if std::env::var_os(IN_NETNS).is_some() {
        return true;
    }
    let exe = std::env::current_exe().expect("test executable path");
    // Whatever the test started and left running (a child of a failed test) is killed and
    // named by run_in_netns when the test ends.
    let out = run_in_netns(
        &format!(
            "'{}' --exact '{name}' --nocapture --test-threads=1",
            exe.display()
        ),
        timeout_s,
        &[
            (IN_NETNS, "1".into()),
            ("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST".into()),
        ],
    );
    let (stdout, stderr) = text(&out);
    // timeout(1): 124 after its SIGTERM, 137 after the SIGKILL 5 s later.
    let how = match out.status.code() {
        Some(124 | 137) => format!("did not finish within {timeout_s} s: killed by timeout"),
        _ => format!("failed ({})", out.status),
    };
    assert!(
        out.status.success() && stdout.contains("1 passed"),
        "{name} in its network namespace {how}\n--- stdout\n{stdout}\n--- stderr\n{stderr}"
    );
    false
}
