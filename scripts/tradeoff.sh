#!/usr/bin/env bash
# Regenerate reports/csw-tradeoff.md and its plots (reports/img/).
set -euo pipefail
set -x
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
python "$here/scripts/tradeoff_report.py" "$here/reports/csw-tradeoff.md"
