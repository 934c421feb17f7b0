# Two commands a new user needs: `make demo` (a whole episode through the HTTP service) and `make test`.
# Everything installs into .venv on first use; torch is the CPU build that lies on local disk.

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: setup test test-slow lint serve demo bench clean

setup: $(STAMP)

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet torch==2.13.0
	$(PY) -m pip install --quiet -e '.[dev]'
	touch $(STAMP)

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy symbolic app agent models harness bench

test: lint
	$(PY) -m pytest -q -m "not slow"

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow

serve: $(STAMP)
	JARVIS_HOST=$(HOST) JARVIS_PORT=$(PORT) $(PY) -m app

demo: $(STAMP)
	$(PY) -m harness demo --port $(PORT)

bench: $(STAMP)
	$(PY) -m bench

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
