#!/usr/bin/env bash
# The whole test suite. pytest's exit code 5 ("no tests collected") is a failure here.
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
# The kernels the suite loads, compiled first on every core (tests/suite_kernels.py).
export CSW_SUITE_PRECOMPILE="${CSW_SUITE_PRECOMPILE:-1}"
set -x
python -m pytest "$@"
status=$?
set +x
if [ "$status" -eq 5 ]; then
    echo "scripts/test.sh: pytest collected no tests; that is a failure" >&2
    exit 1
fi
exit "$status"
