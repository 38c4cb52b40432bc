# Two commands do all the set-up from a fresh clone:
#   make demo   installs into .venv (with the [fast] and [pandas] extras) and runs the
#               gathering scenario on the compiled engine into runs/gathering/
#   make lessons  installs JupyterLab (the [lessons] extra) and opens lesson 01 of notebooks/
#               (lesson 09 shows the studio: it builds the front-end too)
#   make docs   installs the [docs] extra (and the extras the lessons and the pages' examples
#               use) and builds the documentation site into site/ (lessons executed,
#               warnings as errors, links checked)
#   make test   installs the test dependencies (JupyterLab among them, and the [docs], [x8],
#               [dask], [video], [fast], [pandas] and [experiments] extras, and chromium when
#               missing) into .venv and runs the suite
#   (demo, lessons and test also build the studio's front-end with npm: pyaa studio,
#   docs/studio.md)
PYTHON ?= python3
VENV ?= .venv
BIN := $(VENV)/bin

.PHONY: demo lessons docs test lint clean browser

$(BIN)/python:
	$(PYTHON) -c 'import sys; sys.exit("Python >= 3.11 is needed" if sys.version_info < (3, 11) else 0)'
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

# The studio's front-end (pyaa studio): Blockly and the page's code, bundled by esbuild into
# the package (src/pyautonomousagent/studio/static/, shipped in the wheel); needs Node.js and npm.
STUDIO_BUNDLE := src/pyautonomousagent/studio/static/studio.js
$(STUDIO_BUNDLE): studio/package.json studio/package-lock.json studio/build.mjs $(wildcard studio/src/*.js)
	cd studio && npm ci --no-audit --no-fund && npm run build

$(VENV)/.installed: pyproject.toml $(STUDIO_BUNDLE) | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[fast,pandas]"
	touch $@

$(VENV)/.installed-test: pyproject.toml $(STUDIO_BUNDLE) | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[test,docs,x8,dask,video,pandas,fast,experiments]"
	touch $@ $(VENV)/.installed $(VENV)/.installed-docs

$(VENV)/.installed-docs: pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[docs,x8,dask,pandas,fast,experiments]"
	touch $@ $(VENV)/.installed

# The compiled engine compiles the gathering tree once (seconds; numba's cache keeps it), so
# that later runs of it, with any parameters, take the compiled engine by themselves (auto).
demo: $(VENV)/.installed
	$(BIN)/pyaa run gathering --out runs/gathering --overwrite --engine compiled
	@echo "Next: the lessons. 'make lessons' opens lesson 01 (notebooks/01_one_drone.ipynb) in JupyterLab."

$(VENV)/.installed-lessons: pyproject.toml $(STUDIO_BUNDLE) | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e ".[fast,lessons]"
	touch $@ $(VENV)/.installed

# JupyterLab on lesson 01 (Ctrl-C stops it); e.g. LAB_ARGS=--no-browser on a machine without one.
# As root (a container), JupyterLab wants --allow-root.
lessons: $(VENV)/.installed-lessons
	$(BIN)/jupyter lab notebooks/01_one_drone.ipynb $$([ "$$(id -u)" = 0 ] && echo --allow-root) $(LAB_ARGS)

# The documentation site: executes the lessons, builds with sphinx -W, checks the links.
docs: $(VENV)/.installed-docs
	$(BIN)/python scripts/build_docs.py --out site

# The browser tests (the replay, the studio, the studio in JupyterLab) drive Debian's chromium;
# install it when missing and we can (root).
browser:
	@if [ ! -x /usr/bin/chromium ] || ! command -v chromedriver >/dev/null; then \
	  if [ "$$(id -u)" = 0 ] && command -v apt-get >/dev/null; then \
	    apt-get update && apt-get install -y chromium chromium-driver; \
	  else \
	    echo "no chromium: the browser test will be skipped (apt-get install chromium chromium-driver)"; \
	  fi; \
	fi

# The suite on two workers (pytest-xdist): CI has 2 cores, and a worker waits on numba's
# compiles and on subprocesses much of the time. Tests of one xdist_group run on one worker
# (the lessons, executed once for the tests that read them, not once per worker; the tests
# sharing a module's fixture). The groups go out in the order of the tests (tests/conftest.py
# puts the lessons', the longest, first), not the largest first.
test: $(VENV)/.installed-test browser
	$(BIN)/ruff check src tests
	$(BIN)/mypy src
	$(BIN)/python -m pytest -n 2 --dist loadgroup --no-loadscope-reorder --durations=25

lint: $(VENV)/.installed-test
	$(BIN)/ruff check src tests
	$(BIN)/ruff format --check src tests
	$(BIN)/mypy src

clean:
	rm -rf $(VENV) runs site .pytest_cache .mypy_cache .ruff_cache
