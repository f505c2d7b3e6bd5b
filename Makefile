# Two entry points: `make demo` (set-up and the main job) and `make test` (set-up and the tests).
# Both install the Python packages into .venv (pip install -e ".[dev]": the package, all its extras, the
# test tools); neither installs system packages: `make system-packages` does (as root on Debian), and
# .ci/run calls it.  The FMUs are built for this machine into build/fmus, once: `make test` builds them
# there (the tests use them), `make check` and `make demo` reuse them; `make dist` builds the
# distributable ones (Windows and macOS binaries too, cross-compiled with zig) into build/dist.
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.installed
FMUS := build/fmus

.PHONY: demo test test-slow test-all check dist system-packages compare bench clean

$(STAMP): pyproject.toml
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install --quiet --upgrade pip
	$(PY) -m pip install --quiet -e ".[dev]"
	touch $(STAMP)

demo: $(STAMP)
	$(PY) -m orchestration build --out $(FMUS) --if-stale
	$(PY) -m orchestration run scenarios/ramp_rated_load.yaml --out results --fmus $(FMUS)

compare: $(STAMP)
	$(PY) demos/compare_controllers.py --out results

# the tests build the FMUs into $(FMUS) when missing or stale (tests/conftest.py), once per run (once for
# all pytest-xdist workers: a file lock); -n auto: a worker per core.  `make test` runs every test but
# those marked slow (co-simulation runs, child processes, signals, sanitizers, valgrind, the cross-compiled
# FMUs: tests/conftest.py marks the last three); `make test-slow` runs those; CI (.ci/run) runs both
test: $(STAMP)
	@./scripts/system_packages.sh --check
	$(PY) -m ruff check .
	SATMOTOR_TEST_FMUS=$(FMUS) $(PY) -m pytest -n auto -m "not slow"

test-slow: $(STAMP)
	@./scripts/system_packages.sh --check
	SATMOTOR_TEST_FMUS=$(FMUS) $(PY) -m pytest -n auto -m slow

test-all: test test-slow

check: $(STAMP)
	$(PY) -m orchestration build --out $(FMUS) --if-stale
	$(PY) -m orchestration check $(FMUS)/*.fmu $(FMUS)/native/*.fmu $(FMUS)/native-fmi3/*.fmu $(FMUS)/native-me/*.fmu $(FMUS)/native-me-fmi3/*.fmu --junit build/check.xml

# the distributable FMUs: the native ones for Linux (glibc >= 2.17), Windows and macOS (zig cc; on a
# fresh machine zig first compiles its C runtimes for them: minutes)
dist: $(STAMP)
	$(PY) -m orchestration build --out build/dist --all-platforms

# valgrind, gcc, binutils, wine: the system tools some tests use (scripts/system_packages.sh says why)
system-packages:
	./scripts/system_packages.sh

bench: $(STAMP)
	$(PY) -m pip install --quiet -e ".[dev,bench]"
	$(PY) -m bench all

clean:
	rm -rf $(VENV) results build
