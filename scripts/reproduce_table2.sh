#!/usr/bin/env bash
# Regenerate reports/table2.md: the paper's TABLE II measured on this machine.
# Needs the Middlebury data: CSW_DATA_DIR, the user cache, or network for the download.
set -euo pipefail
set -x
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
if [ -z "${CSW_DATA_DIR:-}" ] && [ -d "$here/../shared/datasets" ]; then
    export CSW_DATA_DIR="$here/../shared/datasets"
fi
mkdir -p "$here/reports"
python "$here/scripts/table2_report.py" "$here/reports/table2.md"
