# Two commands do all the set-up: `make demo` and `make test`. Each creates .venv and installs first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast bench clean debian-packages

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[test,ml,dask,live]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/chronofuse run --out out/demo

# Debian packages the tests run (RTKLIB's rnx2rtkp as an independent positioning solution); CI runs as root.
DEBIAN_PACKAGES := rtklib

debian-packages:
	@command -v rnx2rtkp >/dev/null || (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(DEBIAN_PACKAGES))

test: $(STAMP) debian-packages
	$(BIN)/python -m pytest -n 2 --durations=15

test-fast: $(STAMP)
	$(BIN)/python -m pytest -n 2 -m "not slow"

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) out
