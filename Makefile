# mavhelm — `make demo` runs the demo mission in the built-in simulator, `make test` the suite,
# `make test-fast` the suite without the tests marked slow.
# The distribution's Python 3.11 when there is one: Debian's optimised build runs pure Python
# ~15 % and pNav's EKF ~25 % faster than a plain source build (pyenv's default) here;
# any python3 otherwise, and whenever the first cannot make a venv.
PYTHON ?= $(firstword $(wildcard /usr/bin/python3.11) python3)
VENV   ?= .venv
BIN     = $(VENV)/bin

.PHONY: demo test test-fast lint bench params clean

# The real ArduPilot SITL beside the checkout, when there is one: its tests and benchmarks run
# (the variable may also be given by the caller; .ci/run sets it the same way).
MAVHELM_ARDUPILOT ?= $(wildcard $(CURDIR)/../shared/ardupilot/ardurover)
export MAVHELM_ARDUPILOT
MAVHELM_ARDUSUB ?= $(wildcard $(CURDIR)/../shared/ardupilot/ardusub)
export MAVHELM_ARDUSUB

$(BIN)/.installed: pyproject.toml
	$(PYTHON) -m venv $(VENV) || { rm -rf $(VENV) && python3 -m venv $(VENV); }
	$(BIN)/python -m pip install -q --upgrade pip
	$(BIN)/python -m pip install -q -e '.[test]'
	touch $@

demo: $(BIN)/.installed
	$(BIN)/mavhelm demo examples/demo.moos

# The tests in two passes (tests/conftest.py, LIVE): the CPU-bound ones on two workers, then
# the live ones (real SITL, companion, browser, pty) one after another, alone on the machine.
# Both passes run; either failing fails the target. The live pass names its slowest tests
# (most of CI's time is theirs: real SITL minutes).
# $(call two_passes,MARKS): the tests also selected by MARKS ("" or "not slow and ").
two_passes = status=0; \
	$(BIN)/python -m pytest -q -m "$(1)not live" -n 2 --dist loadfile || status=1; \
	$(BIN)/python -m pytest -q -m "$(1)live" --durations=12 || status=1; \
	exit $$status

test: $(BIN)/.installed
	$(BIN)/ruff check mavhelm tests benchmarks
	$(BIN)/mypy
	$(call two_passes,)

test-fast: $(BIN)/.installed
	$(BIN)/ruff check mavhelm tests benchmarks
	$(BIN)/mypy
	$(call two_passes,not slow and )

bench: $(BIN)/.installed
	$(BIN)/python -m benchmarks.bench_demo
	$(BIN)/python -m benchmarks.bench_hour_mission
	$(BIN)/python -m benchmarks.bench_sim_alone
	$(BIN)/python -m benchmarks.bench_link
	$(BIN)/python -m benchmarks.bench_ardupilot_demo
	$(BIN)/python -m benchmarks.bench_tracking
	$(BIN)/python -m benchmarks.bench_nav
	$(BIN)/python -m benchmarks.bench_nav_ardupilot
	$(BIN)/python -m benchmarks.bench_step_response
	$(BIN)/python -m benchmarks.bench_braking
	$(BIN)/python -m benchmarks.bench_lsq
	$(BIN)/python -m benchmarks.bench_web

params: $(BIN)/.installed
	$(BIN)/mavhelm params > docs/parameters.md

lint: $(BIN)/.installed
	$(BIN)/ruff check mavhelm tests benchmarks
	$(BIN)/mypy

clean:
	rm -rf $(VENV) runs .pytest_cache .ruff_cache
