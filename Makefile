# Two commands do all set-up on a fresh machine: `make demo` and `make test`.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
# Material for MkDocs prints a banner about MkDocs 2.0 on every build; it is not a warning.
export NO_MKDOCS_2_WARNING := 1

.PHONY: demo serve test docs lint format bench fuzz mutation clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): $(BIN)/python pyproject.toml
	$(BIN)/python -m pip install --quiet -e ".[test,docs]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/mtm demo --out mtm-demo

# The web application on http://127.0.0.1:8000 over a demonstration laboratory built from
# `mtm demo`'s output (users admin, engineer, viewer; password demo-password).
serve: $(STAMP)
	test -f mtm-demo/.mtm-demo || $(BIN)/mtm demo --out mtm-demo
	test -f mtm-demo/lab.sqlite || \
		$(BIN)/mtm serve demo-lab --from mtm-demo --db mtm-demo/lab.sqlite
	$(BIN)/mtm serve --db mtm-demo/lab.sqlite

test: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	# Two pytest workers fill the two cores; a threaded BLAS in each would oversubscribe
	# them (a 238 x 238 eigh went from milliseconds to 0.7 s under that contention).
	OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 $(BIN)/python -m pytest -n 2 -q
	# Without --quiet: --quiet hides the warnings, and --strict fails only on warnings it logs.
	$(BIN)/mkdocs build --strict --site-dir "$$(mktemp -d)"

docs: $(STAMP)
	$(BIN)/mkdocs build --strict

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

format: $(STAMP)
	$(BIN)/ruff format .
	$(BIN)/ruff check --fix .

# The whole fuzz corpus (CI runs a sample of it with `make test`): every catalogue case,
# many hypothesis examples per strategy, 20 SIGINT and 20 SIGKILL runs; prints the census.
fuzz: $(STAMP)
	MTM_FUZZ=all $(BIN)/python -m pytest tests/fuzz -q -p no:xdist

# The web benchmark drives the server with wrk, a compiled HTTP load generator (Debian's
# package; a Python client took most of the 2 cores itself): installed here when missing.
bench: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[test,bench]"
	@command -v wrk >/dev/null 2>&1 || ! command -v apt-get >/dev/null 2>&1 || \
	  { export DEBIAN_FRONTEND=noninteractive; apt-get install -y -qq wrk >/dev/null 2>&1 || \
	    { apt-get update -qq && apt-get install -y -qq wrk >/dev/null; }; }
	$(BIN)/python bench/run_all.py

# Mutation testing on demand, not in CI (tests/MUTATION.md): `make mutation`, or
# `make mutation GROUPS="units optimize" MUTATION_ARGS="--sample 300"`.
mutation: $(STAMP)
	$(BIN)/python -m pip install --quiet -e ".[test,mutation]"
	nice -n 19 $(BIN)/python tools/mutation.py $(GROUPS) $(MUTATION_ARGS)

clean:
	rm -rf $(VENV) build dist site src/*.egg-info .pytest_cache .ruff_cache .hypothesis
