# Two entry points: `make demo` and `make test`. Each builds .venv on first use: pip without
# byte-compiling everything it installs, then only what the project imports, on both cores
# (scripts/warm_bytecode.py; docs/performance.md).
SHELL  := /bin/bash
PYTHON ?= python3
VENV   := .venv
BIN    := $(VENV)/bin
STAMP  := $(VENV)/.installed
OUT    ?= out/demo
SEED   ?= 0

.PHONY: demo test lint bench clean venv

$(STAMP): pyproject.toml constraints.txt
	$(PYTHON) -m venv $(VENV)
	$(BIN)/pip install --quiet --upgrade pip
	$(BIN)/pip install --quiet --no-compile -c constraints.txt -e ".[rl,ray,dev,fleet]"
	$(BIN)/python scripts/warm_bytecode.py
	touch $(STAMP)

venv: $(STAMP)

demo: $(STAMP)
	$(BIN)/brakewear demo --out $(OUT) --seed $(SEED)

# ruff, then mypy beside the tests (it takes the CPU the tests leave idle; its report is
# printed when both are done, and the tests' summary line again last); two pytest workers,
# whole files each and the files that use Ray on one of them (tests/conftest.py), one
# BLAS/torch thread each (more threads than cores slows both).
test: $(STAMP)
	$(BIN)/ruff check .
	@$(BIN)/mypy > $(VENV)/mypy.log 2>&1 & types=$$!; \
	MPLBACKEND=Agg OMP_NUM_THREADS=1 MKL_NUM_THREADS=1 $(BIN)/python -m pytest -q -n 2 \
	  --dist loadfile --durations=20 | tee $(VENV)/pytest.log; tests=$${PIPESTATUS[0]}; \
	wait $$types; typed=$$?; echo "== mypy"; cat $(VENV)/mypy.log; \
	echo "== pytest"; tail -n 1 $(VENV)/pytest.log; \
	[ $$tests -eq 0 ] && [ $$typed -eq 0 ]

lint: $(STAMP)
	$(BIN)/ruff check .
	$(BIN)/ruff format --check .
	$(BIN)/mypy

bench: $(STAMP)
	for b in benchmarks/bench_*.py; do echo "== $$b"; $(BIN)/python $$b || exit 1; done

clean:
	rm -rf $(VENV) out .pytest_cache
