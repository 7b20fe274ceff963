#!/usr/bin/env bash
# Regenerate reports/quality.md and its pictures (reports/img/quality-*.png): csw's
# pipelines against OpenCV StereoBM and SGBM. Needs the bench extra and the data.
set -euo pipefail
set -x
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
mkdir -p "$here/reports"
python "$here/scripts/quality_report.py" --output "$here/reports/quality.md" "$@"
