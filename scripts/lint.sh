#!/usr/bin/env bash
# Verify only; `make format` fixes.
set -euo pipefail
set -x
ruff check .
