#!/usr/bin/env bash
# Runs the rockwatch demo: the live node and a replay of the bundled Northridge record over
# ROS 2 on loopback, alerts printed as they arrive, then a table of every block.
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --release --quiet -- demo "$@"
