# Two entry points: `make demo` (set-up and the main job) and `make test` (set-up and the tests).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test lint bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(PY) demos/closed_loop.py --out results
	$(PY) demos/compare_controllers.py --out results

test: $(STAMP)
	$(PY) -m ruff check .
	$(PY) -m pytest

bench: $(STAMP)
	$(PY) bench/bench_plant.py
	$(PY) bench/bench_controller.py

clean:
	rm -rf $(VENV) results build
