# Sidewalk — every target creates or reuses .venv by itself.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= runs/latest

.PHONY: run test bench venv clean

venv: $(STAMP)

$(STAMP): pyproject.toml
	test -x $(PY) || $(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	touch $(STAMP)

## The main job: the default mission with every module on loopback Zenoh.
run: $(STAMP)
	$(VENV)/bin/sidewalk run --world campus --mission campus-tour --out $(OUT)

## The test suite (real Zenoh on loopback, real SQLite, real processes).
test: $(STAMP)
	$(PY) -m pytest -q

## Benchmarks: each prints one JSON object.
bench: $(STAMP)
	$(VENV)/bin/sidewalk bench blackboard --json
	$(VENV)/bin/sidewalk bench sim --json

clean:
	rm -rf $(VENV) runs .pytest_cache
