# The two commands of README: `make report` and `make test`. Both set up what is missing.
VENV      := .venv
PY        := $(VENV)/bin/python
STAMP     := $(VENV)/.rtval-installed
SOURCES   := $(shell find demo_cpp mitsuba_ref compare -type f -not -path '*/__pycache__/*') pyproject.toml scripts/setup.sh
SCENE     ?= paper

.PHONY: report test test-cpp test-py bench setup clean

report: $(STAMP)
	$(VENV)/bin/rtval report scenes/$(SCENE).json

test: $(STAMP)
	$(MAKE) --no-print-directory test-cpp test-py

test-cpp: $(STAMP)
	ctest --test-dir build/cmake --output-on-failure -j2

test-py: $(STAMP)
	$(PY) -m pytest -q

bench: $(STAMP)
	$(PY) bench/run_all.py

setup: $(STAMP)

# Re-run set-up when any source changed; pip then rebuilds demo_cpp incrementally.
$(STAMP): $(SOURCES)
	bash scripts/setup.sh
	touch $@

clean:
	rm -rf build $(VENV) reports/*/
