# The two commands of README: `make report` and `make test`. Both set up what is missing.
VENV      := .venv
PY        := $(VENV)/bin/python
STAMP     := $(VENV)/.rtval-installed
SOURCES   := $(shell find demo_cpp -type f -not -path '*/__pycache__/*') pyproject.toml scripts/setup.sh
SCENE     ?= paper
SHELL     := /bin/bash

FUZZ_BIN  := build/fuzz/scene_loader_fuzz
# pytest in parallel (pytest-xdist, one render cache per worker), in a temporary folder of its
# own: pytest's shared /tmp/pytest-of-USER is pruned by every session, racing with others.
PYTEST    := $(PY) -m pytest -q --numprocesses=auto --maxprocesses=4 --dist loadscope
# pip configures build/cmake with the GoogleTest suite and the bench programs and builds rtdemo and
# rtdemo-gl there; make test and make bench build the rest in it, from the same objects.
DEV_BUILD := build/cmake
CPP_FORMATTED := $(shell find demo_cpp bench -type f \( -name '*.cpp' -o -name '*.h' \) | sort)

.PHONY: report test test-fast lint lint-cpp test-cpp test-py test-fuzz test-build fuzz bench bench-build setup clean

report: $(STAMP)
	$(VENV)/bin/rtval report scenes/$(SCENE).json

# The full run CI calls: set-up, linters, then every test; it ends by saying how long it took.
test:
	@start=$$(date +%s); $(MAKE) --no-print-directory setup lint test-cpp test-fuzz test-py; \
	rc=$$?; echo "make test: $$(( $$(date +%s) - start )) s (set-up included), exit $$rc"; exit $$rc

# The inner loop: linters, C++ tests and the quick Python tests (no fuzzing, no slow marks).
test-fast: $(STAMP) test-build
	$(MAKE) --no-print-directory lint test-cpp
	@tmp=$$(mktemp -d /tmp/rtval-pytest.XXXXXX); $(PYTEST) -m "not slow" --basetemp=$$tmp; rc=$$?; rm -rf $$tmp; exit $$rc

# ruff and strict mypy as pyproject.toml configures them, clang-format as demo_cpp/.clang-format,
# and the tree's shape: rooms import downwards only, no import circles, no function over 60 lines
# or 7 parameters.
lint: $(STAMP) lint-cpp
	$(VENV)/bin/ruff check .
	$(VENV)/bin/ruff format --check .
	$(VENV)/bin/mypy
	$(PY) scripts/check_structure.py

# pip configured the folder; ninja re-runs CMake itself when a CMakeLists changes.
test-build: $(STAMP)
	cmake --build $(DEV_BUILD) --target rtdemo_tests

test-cpp: test-build
	ctest --test-dir $(DEV_BUILD) --output-on-failure -j2

test-py: $(STAMP)
	@tmp=$$(mktemp -d /tmp/rtval-pytest.XXXXXX); $(PYTEST) --basetemp=$$tmp; rc=$$?; rm -rf $$tmp; exit $$rc

# Every C++ file under demo_cpp/ and bench/ formatted by demo_cpp/.clang-format.
lint-cpp:
	@clang-format --style=file:demo_cpp/.clang-format --dry-run --Werror $(CPP_FORMATTED)
	@echo "clang-format: $(words $(CPP_FORMATTED)) C++ files as demo_cpp/.clang-format says"

# The C++ scene loader under libFuzzer (clang, ASan, UBSan): 150k runs in `make test`, 10 min in `make fuzz`.
$(FUZZ_BIN): $(STAMP) demo_cpp/fuzz/scene_loader_fuzz.cpp demo_cpp/src/io/scene_loader.cpp
	cmake -S demo_cpp -B build/fuzz -G Ninja -DCMAKE_CXX_COMPILER=clang++ -DRTDEMO_FUZZ=ON \
	  -DBUILD_TESTING=OFF -DCMAKE_BUILD_TYPE=RelWithDebInfo > /dev/null
	cmake --build build/fuzz --target scene_loader_fuzz

# Deterministic in CI (fixed seed and run count, the tracked corpus only); `make fuzz` explores.
# New inputs go to a scratch folder (libFuzzer writes into the first one), emptied each time.
test-fuzz: $(FUZZ_BIN)
	rm -rf build/fuzz/corpus-ci && mkdir -p build/fuzz/corpus-ci
	$(FUZZ_BIN) -seed=1 -runs=150000 -max_total_time=60 -print_final_stats=1 build/fuzz/corpus-ci demo_cpp/fuzz/corpus \
	  2>&1 | grep -E "stat::number_of_executed_units|Done|ERROR|SUMMARY" ; test $${PIPESTATUS[0]} -eq 0

fuzz: $(FUZZ_BIN)
	mkdir -p build/fuzz/corpus
	$(FUZZ_BIN) -max_total_time=600 -print_final_stats=1 build/fuzz/corpus demo_cpp/fuzz/corpus

bench-build: $(STAMP)
	cmake --build $(DEV_BUILD) --target rtdemo rtdemo-gl seed_tracer sphere_test_peak

bench: bench-build
	$(PY) bench/run_all.py

setup: $(STAMP)

# Re-run set-up when any source changed; pip then rebuilds demo_cpp incrementally.
$(STAMP): $(SOURCES)
	bash scripts/setup.sh
	touch $@

clean:
	rm -rf build $(VENV) reports/*/
