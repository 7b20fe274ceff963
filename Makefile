# Set-up and tasks. Every target creates .venv on first use; the work is in scripts/.
VENV ?= .venv
PY := $(VENV)/bin/python
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: run test test-quick test-newest-numba suite-kernels coverage bench bench-batch bench-peers bench-scale bench-startup bench-stream tradeoff quality first-photo \
	bench-rectify bench-calibrate bench-sgm bench-logs lint \
	format clean

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# One stamp per set of extras, rebuilt when pyproject.toml changes.  setuptools' editable
# install prints an "InformationOnly" UserWarning about folders named like the package
# (csw/ is ours, on purpose); it is noise for a user running make, so it is filtered.
PIP_INSTALL := PYTHONWARNINGS=ignore::UserWarning $(PY) -m pip install -q
$(VENV)/.installed-base: pyproject.toml | $(PY)
	$(PIP_INSTALL) -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PIP_INSTALL) -e '.[test]'
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(PY)
	$(PIP_INSTALL) -e '.[dev]'
	touch $@

run: $(VENV)/.installed-base
	scripts/run.sh

test: $(VENV)/.installed-test
	scripts/test.sh

# tests/suite_kernels.txt, the kernel entries a session compiles before its first test,
# written again from the suite on an empty cache (tests/suite_kernels.py).  Minutes.
# Written when the suite ran to its end (pytest's exit 0 or 1: some tests failed).
suite-kernels: $(VENV)/.installed-test
	cache=$$(mktemp -d) || exit 1; \
	CSW_KERNEL_CACHE=$$cache CSW_SUITE_PRECOMPILE=0 scripts/test.sh -q; status=$$?; \
	if [ $$status -le 1 ]; then CSW_KERNEL_CACHE=$$cache $(PY) tests/suite_kernels.py || \
	status=2; fi; rm -rf "$$cache"; [ $$status -le 1 ]

# The suite less the tests marked slow (pyproject.toml's markers).
test-quick: $(VENV)/.installed-test
	scripts/test.sh -m "not slow"

# The quick suite in a venv of its own with the newest Numba the index has, above
# pyproject's bound: what to run before raising that bound.
NEWEST_NUMBA := .venv-newest-numba
test-newest-numba:
	python3 -m venv $(NEWEST_NUMBA)
	$(NEWEST_NUMBA)/bin/python -m pip install -q --upgrade pip
	PYTHONWARNINGS=ignore::UserWarning $(NEWEST_NUMBA)/bin/python -m pip install -q -e '.[test]'
	$(NEWEST_NUMBA)/bin/python -m pip install -q --upgrade numba llvmlite
	$(NEWEST_NUMBA)/bin/python -c "from importlib.metadata import version; print('numba', version('numba'))"
	PATH=$(abspath $(NEWEST_NUMBA))/bin:$$PATH scripts/test.sh -m "not slow"

coverage: $(VENV)/.installed-test
	scripts/coverage.sh

bench: $(VENV)/.installed-dev
	scripts/reproduce_table2.sh

bench-peers: $(VENV)/.installed-dev
	scripts/bench_peers.sh

bench-scale: $(VENV)/.installed-dev
	scripts/bench_scale.sh

bench-startup: $(VENV)/.installed-dev
	scripts/bench_startup.sh

bench-batch: $(VENV)/.installed-dev
	scripts/bench_batch.sh

tradeoff: $(VENV)/.installed-dev
	scripts/tradeoff.sh

quality: $(VENV)/.installed-dev
	scripts/quality.sh

# Rectification against OpenCV, timed, and on real chessboard pairs when
# CSW_CHESSBOARD_DIR holds OpenCV's stereo calibration sample: reports/rectify.md
bench-rectify: $(VENV)/.installed-dev
	$(PY) scripts/rectify_report.py

# csw calibrate + csw rectify against OpenCV's calibrate-and-rectify chain, on the
# chessboard pairs in CSW_CHESSBOARD_DIR (OpenCV's stereo sample): reports/calibrate.md
bench-calibrate: $(VENV)/.installed-dev
	$(PY) scripts/calibrate_report.py --label "OpenCV's stereo calibration sample"

# Streams against StereoBM (frames a second, in process) and whole csw match runs on a
# video against a short OpenCV script: reports/stream.md
bench-stream: $(VENV)/.installed-dev
	$(PY) scripts/stream_report.py

# Semi-global matching against SGBM and StereoBM: speed, streams, memory, stripes:
# reports/sgm.md
bench-sgm: $(VENV)/.installed-dev
	$(PY) scripts/sgm_report.py --output reports/sgm.md

# Three photograph-like pairs no test uses, matched with no range given: reports/first-photo.md
first-photo: $(VENV)/.installed-dev
	$(PY) scripts/first_photo.py

# Robot logs: reading and decoding from MCAP, a 300-frame log against Matcher.stream in
# memory, memory over 10,000 frames: reports/logs.md
bench-logs: $(VENV)/.installed-dev
	$(PY) scripts/logs_report.py

lint: $(VENV)/.installed-dev
	scripts/lint.sh

format: $(VENV)/.installed-dev
	ruff check --fix . && ruff format .

clean:
	rm -rf $(VENV) $(NEWEST_NUMBA) out build *.egg-info .pytest_cache .hypothesis
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
