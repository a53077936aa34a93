# Two commands do all the set-up: `make demo` and `make test`.
# Both create .venv when it is missing and reinstall only when pyproject.toml changes.
PYTHON ?= python3
VENV := .venv
BIN := $(VENV)/bin
STAMP := $(VENV)/.installed
OUT ?= out

.PHONY: demo test bench typecheck clean

$(BIN)/python:
	$(PYTHON) -m venv $(VENV)
	$(BIN)/python -m pip install --quiet --upgrade pip

$(STAMP): pyproject.toml | $(BIN)/python
	$(BIN)/python -m pip install --quiet -e '.[test]'
	touch $(STAMP)

demo: $(STAMP)
	MPLBACKEND=Agg $(BIN)/auv-hinf certify --preset paper-triangle --out $(OUT)/certificate; \
	  status=$$?; if [ $$status -gt 1 ]; then exit $$status; fi
	MPLBACKEND=Agg $(BIN)/auv-hinf simulate --preset paper-triangle --out $(OUT)/simulation
	@echo "plots and JSON written under $(OUT)/"

test: $(STAMP)
	$(BIN)/python -m mypy auv_hinf
	MPLBACKEND=Agg $(BIN)/python -m pytest tests auv_hinf/design.py --doctest-modules --nbmake notebooks

bench: $(STAMP)
	MPLBACKEND=Agg $(BIN)/python benchmarks/run_all.py

typecheck: $(STAMP)
	$(BIN)/python -m mypy auv_hinf

clean:
	rm -rf $(VENV) $(OUT) .pytest_cache
