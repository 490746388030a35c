# Two commands on a fresh machine: `make demo` and `make test` (each sets up what it needs).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
NODE_DIR := tests/node
NODE_STAMP := $(NODE_DIR)/node_modules/.installed
PYTEST_ARGS ?=

.PHONY: demo test bench lint install node-deps clean

$(PY):
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip

# Reinstall only when the dependency pins change; constraints.txt pins the whole environment
# because MuJoCo and numpy versions change simulation results.
$(STAMP): pyproject.toml constraints.txt | $(PY)
	$(PY) -m pip install --quiet -c constraints.txt -e '.[test]'
	touch $(STAMP)

install: $(STAMP)

# Node packages for the independent-client tests (roslibjs, Foxglove's MCAP decoders).
# Without node/npm on the machine those tests skip and say why.
$(NODE_STAMP): $(NODE_DIR)/package.json $(NODE_DIR)/package-lock.json
	@if command -v npm >/dev/null 2>&1; then \
		cd $(NODE_DIR) && npm ci --no-audit --no-fund --loglevel=error && touch node_modules/.installed; \
	else echo "npm not found: node-based tests will skip"; fi

node-deps: $(NODE_STAMP)

demo: install
	$(VENV)/bin/harness demo

lint: install
	$(VENV)/bin/ruff check harness tests bench conftest.py
	$(VENV)/bin/mypy

test: install node-deps lint
	$(PY) -m pytest -n 2 $(PYTEST_ARGS)

bench: install
	$(PY) bench/run.py

clean:
	rm -rf $(VENV) $(NODE_DIR)/node_modules .pytest_cache .mypy_cache .ruff_cache
