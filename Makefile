# fts-calib: `make demo` runs the main job, `make test` the whole test suite.
# Both create .venv when missing and reinstall the package when pyproject.toml changes.

PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out

ROBOTS := ur5 ur10 panda kinova xarm7

.PHONY: demo test lint bench trajectories clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install -qq -e '.[dev]'
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/fts-calib demo --out $(OUT)

test: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python -m pytest -q

lint: $(STAMP)
	$(BIN)/ruff check fts_calib tests bench examples

bench: $(STAMP)
	@for f in bench/bench_*.py; do echo "== $$f"; $(BIN)/python $$f || exit 1; done

# The planned sweeps shipped in trajectories/ (100 Hz, gzip); tests check that planning reproduces them.
trajectories: $(STAMP)
	@for r in $(ROBOTS); do $(BIN)/fts-calib trajectory --robot $$r -o trajectories/$$r --rate 100 --compress | tail -n 1 || exit 1; done

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .ruff_cache
