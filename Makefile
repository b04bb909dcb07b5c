# The two set-up commands of the README: `make demo` and `make test`.
# Each creates .venv and installs the project (with its test, demo and docs extras) when
# missing.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed-stamp

.PHONY: demo test lint typecheck bench docs doctest clean

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test,demo,docs]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/dcstereo demo --output demo-output

# Test workers: the cores, at most 4. They share one numba cache, .numba-cache, each
# kernel compiled once (tests/_site/kernel_cache_lock.py).
JOBS ?= $(shell n=$$(nproc 2>/dev/null || echo 2); [ $$n -gt 4 ] && n=4; echo $$n)

test: $(STAMP)
	$(BIN)/python -m pytest -q -n $(JOBS) --dist worksteal

lint: $(STAMP)
	$(BIN)/ruff check src tests benchmarks scripts docs
	$(BIN)/ruff format --check src tests benchmarks scripts docs

# mypy on the public modules listed in pyproject.toml's [tool.mypy] (also run by
# tests/test_typing.py)
typecheck: $(STAMP)
	$(BIN)/python -m mypy

bench: $(STAMP)
	$(BIN)/python benchmarks/bench_speed.py --markdown docs/speed-tables.md

# The documentation site, docs/_build/html/index.html: warnings are errors, and every
# cross-reference must resolve (-n), so a renamed function breaks the build.
SPHINXOPTS ?= -n -W --keep-going -q
docs: $(STAMP)
	$(BIN)/sphinx-build -b html $(SPHINXOPTS) docs docs/_build/html

# The documentation's examples as doctests: the pages' (Sphinx's doctest builder) and the
# docstrings' (pytest, in their modules' namespaces). They take their kernels from the test
# run's cache, .numba-cache, and leave what they compile there for the next run.
DOCS_CACHE := $(CURDIR)/.numba-cache
doctest: $(STAMP)
	NUMBA_CACHE_DIR=$(DOCS_CACHE) \
	    $(BIN)/sphinx-build -b doctest $(SPHINXOPTS) docs docs/_build/doctest
	NUMBA_CACHE_DIR=$(DOCS_CACHE) \
	    $(BIN)/python -m pytest -q -p no:cacheprovider --doctest-modules src/dcstereo

clean:
	rm -rf $(VENV) demo-output .pytest_cache .numba-cache docs/_build docs/api/generated
