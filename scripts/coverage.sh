#!/usr/bin/env bash
# Line coverage of csw/, its kernels (kernels/) and csw_cli/ over the whole suite; fails
# under 90%.
# The JIT stays on: every line of csw/ and csw_cli/ is Python either way, and with
# NUMBA_DISABLE_JIT=1 the kernels' workers run as plain Python, which takes the suite
# from minutes to hours.  The workers themselves (kernels/jit/) are left out of the
# figure: compiled, coverage can't see them run; tests/kernels/test_no_jit.py runs them
# as Python against the oracle.
set -uo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/_data_env.sh"
set -x
python -m pytest -q -p no:randomly --cov=csw --cov=csw.kernels --cov=csw_cli --cov-report=term:skip-covered \
    --cov-config="$here/scripts/coverage.toml" --cov-fail-under=90 "$@"
