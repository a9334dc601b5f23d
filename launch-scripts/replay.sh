#!/usr/bin/env bash
# Replays the bundled Rinaldi record (228° + UP) to a running node over ROS 2 as CI.RRS.00
# at 10× real time; extra arguments are passed on (e.g. --speed 1, --loop 3).
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --release --quiet -- replay \
  --record tests/data/records/Rinaldi228.AT2 --vertical tests/data/records/RinaldiUP.AT2 \
  --azimuth 228 --station CI.RRS.00 --transport ros2 --speed 10 "$@"
