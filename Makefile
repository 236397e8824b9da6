# The README's commands. Each target does the set-up itself when it is missing or stale.
SHELL := /bin/bash
PYTHON ?= python3
VENV := .venv
PACKAGES := com_interfaces src/com_core com_estimator wrench_sim exploration_sequencer
VENV_STAMP := $(VENV)/.installed
BUILD_STAMP := install/.built
# control_msgs's definitions the project uses, built only where no control_msgs imports
CONTROL_MSGS := interfaces/control_msgs
PACKAGE_FILES := $(shell find $(PACKAGES) $(CONTROL_MSGS) -name setup.py -o -name setup.cfg \
	-o -name package.xml -o -name CMakeLists.txt -o -name '*.action' -o -name '*.msg')
IN_ENV := source ./env.sh &&
ARGS ?=

.PHONY: setup demo test test-fast lint bench study clean

setup: $(BUILD_STAMP)

$(VENV_STAMP): requirements.txt constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(VENV)/bin/pip install --disable-pip-version-check -q pip==25.3
	$(VENV)/bin/pip install --disable-pip-version-check -q -r requirements.txt -c constraints.txt
	$(VENV)/bin/pip install --disable-pip-version-check -q --no-deps --no-build-isolation -e src/com_core
	touch $(VENV)/COLCON_IGNORE $@

$(BUILD_STAMP): $(VENV_STAMP) $(PACKAGE_FILES)
	# the ROS wheels install their CMake packages (ament_cmake, rosidl) under the venv
	source $(VENV)/bin/activate && \
		export AMENT_PREFIX_PATH="$$VIRTUAL_ENV$${AMENT_PREFIX_PATH:+:$$AMENT_PREFIX_PATH}" && \
		export CMAKE_PREFIX_PATH="$$VIRTUAL_ENV$${CMAKE_PREFIX_PATH:+:$$CMAKE_PREFIX_PATH}" && \
		paths="$(PACKAGES)" && \
		if ! PYTHONPATH="$$(tr ':' '\n' <<< "$${PYTHONPATH:-}" | grep -v '^$(CURDIR)/install/' \
			| paste -sd:)" python -c "import control_msgs.action" 2>/dev/null; then \
			paths="$$paths $(CONTROL_MSGS)"; fi && \
		colcon build --symlink-install --base-paths $$paths \
		--event-handlers console_cohesion- summary-
	touch $@

demo: setup
	$(IN_ENV) python -m exploration_sequencer.demo $(ARGS)

study: setup
	$(IN_ENV) python -m com_core.paper.study $(ARGS)

# Every test: those without node processes on every core (as test-fast, with the Monte
# Carlo statistics), then the system tests one at a time (each runs its nodes on the
# cores). A selection (ARGS, e.g. -k) that leaves one half empty passes that half.
test: setup lint
	$(IN_ENV) python -m pytest test -m "not system" -n auto --dist worksteal $(ARGS); \
		code=$$?; [ $$code -eq 0 ] || [ $$code -eq 5 ]
	$(IN_ENV) python -m pytest test -m system $(ARGS); code=$$?; [ $$code -eq 0 ] || [ $$code -eq 5 ]

# The core and unit tests: no node processes, no rclpy context (the `system` marker), no
# Monte Carlo statistics over hundreds of fits (the `slow` marker); on every core
# (pytest-xdist: each worker takes its share of the tests in file order and takes over
# another's when it runs out, so a module's shared fixtures are mostly built once).
test-fast: setup lint
	$(IN_ENV) python -m pytest test -m "not system and not slow" -n auto --dist worksteal $(ARGS)

lint: $(VENV_STAMP)
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .

bench: setup
	$(IN_ENV) python bench/estimator_efficiency.py
	$(IN_ENV) python bench/sim_rate.py --subscriber
	$(IN_ENV) python bench/estimator_rate.py
	$(IN_ENV) python bench/replay_rate.py
	$(IN_ENV) python bench/exploration.py --runs 50

clean:
	rm -rf build install log
