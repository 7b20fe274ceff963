# Set-up and tasks. Every target creates .venv on first use; the work is in scripts/.
VENV ?= .venv
PY := $(VENV)/bin/python
export PATH := $(abspath $(VENV))/bin:$(PATH)

.PHONY: run test bench bench-peers tradeoff lint format clean

$(PY):
	python3 -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip

# One stamp per set of extras, rebuilt when pyproject.toml changes.
$(VENV)/.installed-base: pyproject.toml | $(PY)
	$(PY) -m pip install -q -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml | $(PY)
	$(PY) -m pip install -q -e '.[test]'
	touch $@

$(VENV)/.installed-dev: pyproject.toml | $(PY)
	$(PY) -m pip install -q -e '.[dev]'
	touch $@

run: $(VENV)/.installed-base
	scripts/run.sh

test: $(VENV)/.installed-test
	scripts/test.sh

bench: $(VENV)/.installed-dev
	scripts/reproduce_table2.sh

bench-peers: $(VENV)/.installed-dev
	scripts/bench_peers.sh

tradeoff: $(VENV)/.installed-dev
	scripts/tradeoff.sh

lint: $(VENV)/.installed-dev
	scripts/lint.sh

format: $(VENV)/.installed-dev
	ruff check --fix . && ruff format .

clean:
	rm -rf $(VENV) out build *.egg-info .pytest_cache .hypothesis
	find . -name __pycache__ -type d -prune -exec rm -rf {} +
