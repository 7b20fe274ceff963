#!/usr/bin/env bash
# csw's fast engine vs OpenCV StereoBM in one run; writes reports/peers.md.
# Needs the bench extra (opencv-python-headless) and the Middlebury data.
set -euo pipefail
set -x
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
mkdir -p "$here/reports"
python "$here/scripts/bench_peers.py" --output "$here/reports/peers.md" "$@"
