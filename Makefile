# meshplan: `make demo` and `make test` set up .venv from nothing and run.
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed-stamp

.PHONY: demo test bench clean lint browser smoke unit

$(STAMP): pyproject.toml
	test -x $(BIN)/python || $(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip
	$(BIN)/python -m pip install --quiet -e ".[test]"
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/meshplan synth --preset apartment --seed 1 --output demo-out/scan --force
	$(BIN)/meshplan run demo-out/scan/scan.obj --annotations demo-out/scan/annotations.json --output demo-out/plans --force
	@echo "Plans, models and plan.json are in demo-out/plans/ (open drafting-0.png, pen-and-ink-0.png, report.html)."

# The report's browser tests run in Debian's Chromium; install it when we can (root with apt),
# else those tests are skipped with a message saying so.
browser:
	@test -x /usr/bin/chromium || { command -v apt-get >/dev/null && [ "$$(id -u)" = 0 ] && \
	  { DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1 || \
	    { apt-get update -q >/dev/null 2>&1 && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium >/dev/null 2>&1; }; }; } || \
	  echo "Chromium could not be installed: the browser tests will be skipped"

test: $(STAMP) browser lint smoke
	$(BIN)/python -m pytest -n 2 -q --doctest-modules src/meshplan tests

# The unit layer: every test but the whole runs of meshplan and the real scans, in seconds.
unit: $(STAMP)
	$(BIN)/python -m pytest -n 2 -q -m "not slow and not realscan" tests

# Gates: the linter (pyflakes, pycodestyle, isort, pyupgrade, bugbear, numpy docstrings) and the
# type checker on the package (the linter on the tests, scripts and benchmarks too), both configured in pyproject.toml.
lint: $(STAMP)
	$(BIN)/ruff check src tests scripts benchmarks
	$(BIN)/mypy

# A plain `pip install meshplan` (the wheel and its declared dependencies, no extras) in a new
# bare virtual environment: --version, synth and run must work there.
smoke: $(STAMP)
	PYTHON=$(BIN)/python bash scripts/smoke-install.sh

bench: $(STAMP)
	$(BIN)/python benchmarks/bench.py

clean:
	rm -rf demo-out bench-out meshplan-out gallery-out .pytest_cache .hypothesis

# Every real scan in ../shared/scans through meshplan run (2 at once), scored against
# ../shared/truth: a contact sheet per scan and summary.md/summary.json in gallery-out/.
.PHONY: gallery
gallery: $(STAMP)
	$(BIN)/python scripts/gallery.py --scans ../shared/scans --truth ../shared/truth --output gallery-out --workers 2
