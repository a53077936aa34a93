# Two commands do all the set-up: `make demo` and `make test`.
# Both create .venv when it is missing and reinstall only when pyproject.toml changes.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out
DOCS_OUT := docs/_build/html

# Figures are written to files: no display is needed anywhere (notebooks, docs, CLI).
export MPLBACKEND := Agg

.PHONY: demo test quick lint typecheck pytest coverage docs bench clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test,slycot]'
	touch $(STAMP)

demo: $(STAMP)
	$(BIN)/auv-hinf certify --preset paper-triangle --out $(OUT)/certificate; \
	  status=$$?; if [ $$status -gt 1 ]; then exit $$status; fi
	$(BIN)/auv-hinf simulate --preset paper-triangle --out $(OUT)/simulation
	@echo "plots and JSON written under $(OUT)/"

# Lint and format check, strict typing and the documentation with warnings as errors (side by
# side: each is one process), then the tests, the doctests and the notebooks (nbmake executes
# them).
test: $(STAMP)
	$(MAKE) --no-print-directory -j2 --output-sync=target lint typecheck docs
	$(MAKE) --no-print-directory pytest

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .

typecheck: $(STAMP)
	$(BIN)/python -m mypy auv_hinf

# The tests run on TEST_WORKERS processes (pytest-xdist), one test file per process at a
# time so that module fixtures are built once. The notebooks are collected first: they are
# among the longest files, and handed out last they leave one worker idle at the end. BLAS
# gets one thread per process: the matrices are small, and on a busy 2-core machine two
# BLAS threads spin-wait (one test then takes 7 s instead of 0.03 s). OpenBLAS is also
# held to one kernel family (AVX2, "Haswell"): its AVX-512 kernels round differently, and
# the interior-point SDPs of the robust certificate land on different (equally verified)
# points, which moves recorded numbers by up to 16 %; with one kernel family the recorded
# outputs reproduce on every x86-64 machine.
TEST_WORKERS ?= 2
PIN_BLAS := OPENBLAS_NUM_THREADS=1 OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 OPENBLAS_CORETYPE=Haswell

pytest: $(STAMP)
	$(PIN_BLAS) $(BIN)/python -m pytest --nbmake notebooks tests auv_hinf --doctest-modules \
	  -n $(TEST_WORKERS) --dist loadfile

# The same run with line coverage (about 25 % more CPU, so not part of `make test`).
coverage: $(STAMP)
	$(PIN_BLAS) $(BIN)/python -m pytest --nbmake notebooks tests auv_hinf --doctest-modules \
	  -n $(TEST_WORKERS) --dist loadfile --cov=auv_hinf --cov-report=term:skip-covered

# The fast subset for the edit-test loop, under 45 s on 2 cores: the tests not marked slow
# (full simulations, large N, the recorded outputs) and the doctests; `make test` runs them all.
quick: $(STAMP)
	$(PIN_BLAS) $(BIN)/python -m pytest tests auv_hinf --doctest-modules -m "not slow" -q \
	  -n $(TEST_WORKERS) --dist loadfile

# Notebooks are rendered as stored (no outputs, no execution); see docs/conf.py.
docs: $(STAMP)
	$(BIN)/python -m sphinx -W --keep-going -b html -q docs $(DOCS_OUT)
	@echo "documentation written to $(DOCS_OUT)/index.html"

bench: $(STAMP)
	$(BIN)/python benchmarks/run_all.py

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache .mypy_cache .ruff_cache .hypothesis .coverage \
	  docs/_build docs/api/generated docs/notebooks
