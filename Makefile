# Two commands do all the set-up: `make demo` and `make test`. Each creates .venv and installs first.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed

.PHONY: demo test test-fast bench docs clean debian-packages

# The real parts the tests start (Debian's packages): RTKLIB's rnx2rtkp (an independent positioning
# solution), chronyd and chronyc, gpsd and gpsfake, headless Chromium and its driver. Installed when one is
# missing (CI runs as root on a clean machine).
DEBIAN_PACKAGES := rtklib chrony gpsd gpsd-clients chromium chromium-driver
DEBIAN_TOOLS := rnx2rtkp chronyd chronyc gpsd gpsfake chromium chromedriver

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -c constraints.txt -e ".[test,ml,dask,live,docs]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/chronofuse run --out out/demo

debian-packages:
	@for tool in $(DEBIAN_TOOLS); do PATH="$$PATH:/usr/sbin" command -v $$tool >/dev/null || missing=1; done; \
	if [ -n "$$missing" ]; then \
	  echo "installing Debian packages: $(DEBIAN_PACKAGES)"; \
	  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends $(DEBIAN_PACKAGES); \
	fi

test: $(STAMP) debian-packages
	$(BIN)/python -m pytest -n 2 --durations=15

test-fast: $(STAMP) debian-packages
	$(BIN)/python -m pytest -n 2 -m "not slow"

# The docs site, strict: any warning (a broken link, a docstring that does not parse, a notebook cell that
# fails) fails the build. The test suite builds it too (tests/test_docs_site.py).
docs: $(STAMP)
	$(BIN)/python -m sphinx -W --keep-going -b html docs out/docs

bench: $(STAMP)
	$(BIN)/python benchmarks/run.py

clean:
	rm -rf $(VENV) out
