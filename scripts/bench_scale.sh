#!/usr/bin/env bash
# Regenerate reports/scale.md: many pairs on Dask workers, the cost of row stripes, and a
# 20000 x 20000 pair matched within a memory limit. Needs the dask extra; no data, no network.
# CSW_SCALE_WORK=DIR keeps the generated pairs there between runs (they take minutes).
set -euo pipefail
set -x
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mkdir -p "$here/reports"
python "$here/scripts/scale_report.py" --output "$here/reports/scale.md" \
    ${CSW_SCALE_WORK:+--work "$CSW_SCALE_WORK"} "$@"
