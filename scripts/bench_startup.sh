#!/usr/bin/env bash
# Regenerate reports/startup.md: whole-process times of csw, cold and warm, against a
# short script calling OpenCV's StereoBM. Needs the bench extra and tsukuba's data.
set -euo pipefail
set -x
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
mkdir -p "$here/reports"
cd "$here/scripts"
python "$here/scripts/startup_report.py" --output "$here/reports/startup.md" "$@"
