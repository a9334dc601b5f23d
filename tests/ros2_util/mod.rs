//! Shared by the ROS 2 tests: every DDS test runs its processes in a fresh network namespace
//! (`unshare -n`, loopback up, plus a veth pair with an address and a multicast route, so a
//! participant that ignored the loopback restriction would send on it), bounded in time.

#![allow(dead_code)]

use std::path::PathBuf;
use std::process::{Command, Output};

/// The rockwatch binary under test.
pub fn rockwatch() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_rockwatch"))
}

pub fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

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

/// Runs `script` (sh) in a new network namespace with `timeout_s` as a hard bound.
pub fn run_in_netns(script: &str, timeout_s: u32, envs: &[(&str, String)]) -> Output {
    let mut cmd = Command::new("timeout");
    cmd.arg("-k")
        .arg("5")
        .arg(timeout_s.to_string())
        .arg("unshare")
        .arg("-n")
        .arg("sh")
        .arg("-c")
        .arg(format!("set -e; {NETNS_SETUP}; {script}"))
        .env_remove("ROS_DOMAIN_ID")
        .env_remove("ROS_AUTOMATIC_DISCOVERY_RANGE");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    cmd.output()
        .expect("run timeout/unshare (util-linux, coreutils)")
}

pub fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}
