# Two entry points: `make demo` (set-up and the main job) and `make test` (set-up and the tests).
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast check compare bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m orchestration build --out build/fmus
	$(PY) -m orchestration run scenarios/ramp_rated_load.yaml --out results --fmus build/fmus

compare: $(STAMP)
	$(PY) demos/compare_controllers.py --out results

test: $(STAMP)
	./scripts/system_packages.sh
	$(PY) -m ruff check .
	$(PY) -m pytest

check: $(STAMP)
	$(PY) -m orchestration build --out build/fmus
	$(PY) -m orchestration check build/fmus/*.fmu build/fmus/native/*.fmu build/fmus/native-fmi3/*.fmu --junit build/check.xml

test-fast: $(STAMP)
	$(PY) -m pytest -m "not slow"

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[dev,bench]"
	$(PY) bench/bench_plant.py
	$(PY) bench/bench_controller.py
	$(PY) bench/bench_cosim.py
	$(PY) bench/bench_native.py
	$(PY) bench/bench_libcosim.py
	$(PY) bench/bench_batch.py
	$(PY) bench/bench_peers.py

clean:
	rm -rf $(VENV) results build
