#!/usr/bin/env bash
# Runs the live node (ROS 2) with config/node.toml; extra arguments are passed on
# (e.g. --state-dir /var/lib/rockwatch). Set ROS_DOMAIN_ID / ROS_AUTOMATIC_DISCOVERY_RANGE
# as for any ROS 2 node (LOCALHOST keeps DDS on loopback).
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --release --quiet -- node --config config/node.toml "$@"
