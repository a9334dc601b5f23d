#!/usr/bin/env bash
# Runs the rockwatch demo (bundled Northridge record through the block engine).
set -euo pipefail
cd "$(dirname "$0")/.."
exec cargo run --release --quiet -- demo "$@"
