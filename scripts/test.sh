#!/usr/bin/env bash
# The whole test suite. pytest's exit code 5 ("no tests collected") is a failure here.
set -uo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
# Real-data tests find the Middlebury pairs here unless CSW_DATA_DIR says otherwise.
if [ -z "${CSW_DATA_DIR:-}" ] && [ -d "$here/../shared/datasets" ]; then
    export CSW_DATA_DIR="$here/../shared/datasets"
fi
set -x
python -m pytest "$@"
status=$?
set +x
if [ "$status" -eq 5 ]; then
    echo "scripts/test.sh: pytest collected no tests; that is a failure" >&2
    exit 1
fi
exit "$status"
