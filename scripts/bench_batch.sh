#!/usr/bin/env bash
# Regenerate reports/batch.md: 1000 small pairs here and on 2 local Dask workers (pairs/s,
# overhead per pair, memory after 100 and 1000 pairs). Needs the dask extra; no data.
set -euo pipefail
set -x
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mkdir -p "$here/reports"
cd "$here/scripts"
python "$here/scripts/batch_report.py" --output "$here/reports/batch.md" "$@"
