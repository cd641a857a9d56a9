# The README's two commands. Both create .venv (python3 -m venv) when it is missing.
#   make demo   install the package, run the main scenario, write out/
#   make test   install the test extras and the Debian packages the tests need, run ruff, then pytest
#               (on the compiled kernels, then the kernels' tests again on their numpy versions);
#               then the compat part of the suite on each of COMPAT_PYTHONS, each in its own .venv-X.Y
# and the benchmarks: make bench (in .venv), make bench-peers (PlaCo, in its own .venv-peers).
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
PEERS := .venv-peers
OUT ?= out
SCENARIO ?= walk_then_interact

# Install the Debian package of each "command:package" pair whose command is missing.
define apt_need
	@missing=""; for pair in $(1); do command -v $${pair%%:*} >/dev/null 2>&1 || missing="$$missing $${pair##*:}"; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing with apt-get:$$missing"; \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && \
	  DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
endef

# The Pythons the package claims besides the machine's python3 (pyproject's requires-python), each
# tested in its own virtual environment with the newest drake, numpy and scipy pip resolves there.
COMPAT_PYTHONS ?= 3.11 3.12 3.13
# What runs there: every test but the scenario simulations and the slow ones, plus every scenario's
# construction and first ticks and the case study to its end (the compat marker); the whole suite
# runs once, on python3.
COMPAT_TESTS ?= compat or not (slow or scenario)

.PHONY: demo test test-compat venv bench bench-peers clean

# Shell that prints the first interpreter that runs of $(1) (pythonX.Y, or a path) and pyenv's X.Y
# (which pyenv may not put on PATH), or nothing; the same text works in $(shell) and in a recipe.
find_python = for c in $(1) $$(pyenv root 2>/dev/null)/versions/$(patsubst python%,%,$(notdir $(1)))*/bin/$(notdir $(1)); do \
  "$$c" -c 'import sys' >/dev/null 2>&1 && { echo "$$c"; break; }; done

# The interpreter PYTHON names: itself when it runs (arguments and all), else pyenv's of that
# version, else PYTHON as given (make_venv then says it does not run).
PYTHON_EXE := $(or $(shell $(PYTHON) -c 'import sys' >/dev/null 2>&1 && echo '$(PYTHON)' || { $(call find_python,$(PYTHON)); }),$(PYTHON))

# Create the virtual environment $(1) with an upgraded pip. An interpreter that does not run is named
# (no apt-get for it); Debian's python3 lacks ensurepip until python3-venv is installed.
define make_venv
	@$(PYTHON_EXE) -c 'import sys' >/dev/null 2>&1 || { \
	  echo "PYTHON=$(PYTHON) does not run (not on PATH, nor a version of pyenv's): name an interpreter, e.g. PYTHON=python3.12 or PYTHON=/usr/bin/python3.12" >&2; exit 1; }
	$(PYTHON_EXE) -m venv $(1) || { \
	  SUDO=$$( [ "$$(id -u)" = 0 ] || echo sudo ); \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq python3-venv && \
	  rm -rf $(1) && $(PYTHON_EXE) -m venv $(1); }
	$(1)/bin/python -m pip install --quiet --upgrade pip
endef

$(BIN)/python:
	$(call make_venv,$(VENV))

# Editable install, which builds the compiled core in place (setup.py); re-run when pyproject.toml,
# setup.py or the core's C++ changes.
KERNEL_SOURCES := setup.py $(wildcard drake_sot/kernels/*.cpp drake_sot/kernels/*.h)
$(VENV)/.installed: pyproject.toml $(KERNEL_SOURCES) | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e .
	touch $@

$(VENV)/.installed-test: pyproject.toml $(VENV)/.installed
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $@

venv: $(VENV)/.installed

# graphviz-pure, a dependency, renders the diagram SVGs: no system package.
demo: $(VENV)/.installed
	$(BIN)/drake-sot run $(SCENARIO) --out $(OUT)

# chromium renders the recorded replay in a test (graphviz-pure, a dependency, renders diagrams).
test: $(VENV)/.installed-test
	$(call apt_need,chromium:chromium)
	$(BIN)/ruff format --check .
	$(BIN)/ruff check .
	$(BIN)/python -m pytest -n 2 --dist loadfile --no-loadscope-reorder
	DRAKE_SOT_KERNELS=numpy $(BIN)/python -m pytest -n 2 --dist loadfile -p no:cacheprovider -m kernels
	$(MAKE) --no-print-directory test-compat

# pythonX.Y on PATH, else pyenv's X.Y; the one python3 already is, skipped. Not found: an error under
# CI (it must test what the README claims), else a printed skip.
test-compat:
	@main=$$($(PYTHON_EXE) -c 'import sys; print("%d.%d" % sys.version_info[:2])'); \
	for v in $(COMPAT_PYTHONS); do \
	  [ "$$v" = "$$main" ] && continue; \
	  py=$$($(call find_python,python$$v)); \
	  if [ -z "$$py" ]; then \
	    echo "Python $$v not found (python$$v on PATH, or pyenv): its run is skipped"; \
	    [ -z "$$CI" ] || { echo "CI tests every Python the README claims: install Python $$v"; exit 1; }; \
	    continue; fi; \
	  $(MAKE) --no-print-directory PYTHON=$$py VENV=.venv-$$v .venv-$$v/.installed-test || exit 1; \
	  .venv-$$v/bin/python -m pytest -n 2 --dist loadfile --no-loadscope-reorder -p no:cacheprovider -m "$(COMPAT_TESTS)" || exit 1; \
	done
bench: $(VENV)/.installed
	PYTHONPATH=$(CURDIR) $(BIN)/python benchmarks/bench_kernels.py
	$(BIN)/python benchmarks/bench_sot.py
	$(BIN)/python benchmarks/bench_walk.py
	$(BIN)/python benchmarks/bench_generalized.py
	$(BIN)/python benchmarks/bench_robots.py

# The peer benchmark against PlaCo, in its own environment: placo 0.10.2 pins pin 3.8 and numpy 2.3,
# so it is no dependency of the package. drake_sot comes from PYTHONPATH (the benchmark uses only its
# pure modules: no Drake wheel); example-robot-data gives both sides the same TALOS model.
$(PEERS)/.installed:
	$(call make_venv,$(PEERS))
	$(PEERS)/bin/python -m pip install --quiet placo==0.10.2 example-robot-data==6.0.0 "scipy>=1.11"
	touch $@

bench-peers: $(PEERS)/.installed
	PYTHONPATH=$(CURDIR) $(PEERS)/bin/python benchmarks/bench_peers.py

clean:
	rm -rf $(VENV) $(VENV)-3.* $(PEERS) $(OUT) .pytest_cache .hypothesis
