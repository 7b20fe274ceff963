#!/usr/bin/env bash
# Regenerate reports/table2.md: the paper's TABLE II measured on this machine.
# Needs the Middlebury data: CSW_DATA_DIR, the user cache, or network for the download.
set -euo pipefail
set -x
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
mkdir -p "$here/reports"
python "$here/scripts/table2_report.py" "$here/reports/table2.md"
