# fts-calib: `make demo` runs the main job, `make test` the whole test suite.
# Both create .venv from the lock file (uv.lock) when missing or when the lock changes.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out
# uv installs what uv.lock pins; its own version is pinned here. Its cache stays in the checkout.
UV_VERSION := 0.13.8
UV := UV_CACHE_DIR=$(CURDIR)/.cache/uv UV_PYTHON_DOWNLOADS=never UV_PROJECT_ENVIRONMENT=$(VENV) $(BIN)/uv

ROBOTS := ur5 ur10 panda kinova xarm7

.PHONY: demo test test-floors lint format lock wheel-check bench trajectories clean

$(BIN)/uv:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --disable-pip-version-check uv==$(UV_VERSION)

# --inexact keeps uv (and pip) in the venv; --frozen installs the lock as it is, never re-resolving.
$(STAMP): pyproject.toml uv.lock | $(BIN)/uv
	$(UV) sync --frozen --inexact --extra dev --quiet
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/fts-calib demo --out $(OUT)

# Two workers (pytest-xdist), a test file to each at a time: its module fixtures are built once.
test: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q -n 2 --dist loadfile

lint: $(STAMP)
	$(BIN)/ruff check fts_calib tests bench examples
	$(BIN)/ruff format --check fts_calib tests bench examples
	$(BIN)/mypy

format: $(STAMP)
	$(BIN)/ruff format fts_calib tests bench examples
	$(BIN)/ruff check --fix fts_calib tests bench examples

# Re-resolve uv.lock from pyproject.toml (newest versions within its ranges).
lock: | $(BIN)/uv
	$(UV) lock --upgrade

# The suite on the lowest versions pyproject.toml allows (its floors), in a throw-away venv.
FLOORS := $(VENV)-floors
test-floors: | $(BIN)/uv
	rm -rf $(FLOORS)
	$(UV) venv --quiet --python $(PYTHON) $(FLOORS)
	$(UV) pip install --quiet --python $(FLOORS)/bin/python --resolution lowest-direct -e '.[dev]'
	MPLBACKEND=Agg $(FLOORS)/bin/python -m pytest -q -p no:cacheprovider
	rm -rf $(FLOORS)

# Build the wheel, install it into a fresh venv and run it from a folder outside the checkout.
wheel-check: $(STAMP)
	$(BIN)/python tests/wheel_check.py

bench: $(STAMP)
	@for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

# The planned sweeps shipped in trajectories/ (100 Hz, gzip); tests check that planning reproduces them.
trajectories: $(STAMP)
	@for r in $(ROBOTS); do $(BIN)/fts-calib trajectory --robot $$r --tool paper_tool -o trajectories/$$r --rate 100 --compress | tail -n 1 || exit 1; done

clean:
	rm -rf $(VENV) $(VENV)-floors $(OUT) .cache .pytest_cache .ruff_cache .mypy_cache build dist
