# Sidewalk — every target creates or reuses .venv by itself.
PYTHON ?= python3
VENV   ?= .venv
PY     := $(VENV)/bin/python
STAMP  := $(VENV)/.installed-stamp
OUT    ?= runs/latest

.PHONY: run test bench venv clean chromium test-hosts test-missions

venv: $(STAMP)

$(STAMP): pyproject.toml
	@# a venv cut short (no pip: its creation was interrupted) is made again, not reused
	$(PY) -m pip --version >/dev/null 2>&1 || $(PYTHON) -m venv --clear $(VENV)
	$(PY) -m pip install -q --upgrade pip
	$(PY) -m pip install -q -e '.[dev]'
	@# compile the simulator's ray caster once into numba's on-disk cache (else the first capture of each new build pays seconds)
	$(PY) -c "from vehicle_sim.scene import Scene; from vehicle_sim.worldfile import load_world; from vehicle_sim.sensors.capture import warm_up; warm_up(Scene(load_world('campus')))"
	touch $(STAMP)

## The main job: the default mission with every module on loopback Zenoh.
run: $(STAMP)
	$(VENV)/bin/sidewalk run --world campus --mission campus-tour --out $(OUT)

## pytest workers for the test targets (pytest-xdist; 0: one process). Two on a 2-core machine: the tests wait on
## processes, sockets and sim time for half of their wall time, so two at once keep both cores busy.
TEST_JOBS ?= 2
XDIST := -n $(TEST_JOBS)

## The test suite (real Zenoh on loopback, real SQLite, real processes, a real browser). Each test file runs on one
## worker (`--dist loadfile`), so a file's module fixtures are built once; the files with the longest tests go first.
test: $(STAMP) chromium
	$(PY) -m pytest -q $(XDIST) --dist loadfile --longest-first

## Whole missions under a fault or a run mode (a killed PILOT, a restarted node, a wedged HELM, the compare
## faults, EDDIE under --secure, a walker in the lane, YARF on marked roads, EDDIE's monitor page; seeds 50-99 of the
## generated streets): tens of seconds each, so kept
## out of `make test`'s ten minutes; CI runs them after it, two at once, the longest first (tests/conftest.py).
test-missions: $(STAMP)
	$(PY) -m pytest -q -m missions $(XDIST) --dist load --longest-first

## The multi-host tests (three and four hosts in network namespaces, a secure mission, a link pulled for 5 s):
## minutes each, so kept out of `make test`'s ten minutes; CI runs them after it.
test-hosts: $(STAMP)
	$(PY) -m pytest -q -m hosts $(XDIST) --dist load --longest-first

## Debian's chromium, which Playwright drives in the monitor's browser test (Playwright's own download cannot work here).
chromium:
	@if [ ! -x /usr/bin/chromium ]; then \
	  if [ "$$(id -u)" = 0 ]; then apt-get update -q && DEBIAN_FRONTEND=noninteractive apt-get install -y -q chromium; \
	  else echo "chromium is missing and we are not root: the monitor's browser test will FAIL; install it with: sudo apt-get install chromium"; fi; \
	fi

## Benchmarks: each prints one JSON object (`bench lockstep`: the comparison's missions in lock-step, lockstep_rtf per architecture); the last two are the campus tour at RTF 50 under each architecture (report.json's figures).
## Each round's two runs are kept in runs/bench-rtf50-<arch>-<UTC time> (runs/bench-rtf50-<arch> links the newest).
bench: $(STAMP)
	$(VENV)/bin/sidewalk bench blackboard --json
	$(VENV)/bin/sidewalk bench sim --json
	$(VENV)/bin/sidewalk bench clock --json
	$(VENV)/bin/sidewalk bench perception --json
	$(VENV)/bin/sidewalk bench parallel --json
	$(VENV)/bin/sidewalk bench record --json
	$(VENV)/bin/sidewalk bench eddie --json
	$(VENV)/bin/sidewalk bench cli --json
	$(VENV)/bin/sidewalk bench terrain-planner --json
	$(VENV)/bin/sidewalk bench terrain --json
	$(VENV)/bin/sidewalk bench lockstep --json
	@mkdir -p runs; for arch in codger eddie; do \
	  out=runs/bench-rtf50-$$arch-$$(date -u +%Y%m%dT%H%M%SZ); \
	  $(VENV)/bin/sidewalk run --mission campus-tour --rtf 50 --arch $$arch --out $$out > $$out.log 2>&1; \
	  rm -rf runs/bench-rtf50-$$arch; ln -s $$(basename $$out) runs/bench-rtf50-$$arch; \
	  $(PY) -c "import json, os, sys; p = os.path.join(sys.argv[3], 'report.json'); r = json.load(open(p)) if os.path.exists(p) else None; \
	    print(json.dumps({'mission': 'campus-tour', 'arch': sys.argv[1], 'rtf_requested': 50.0, 'rtf_achieved': None, 'success': False, 'reason': 'no report.json: see ' + sys.argv[2], 'run': sys.argv[3]} if r is None else \
	      {'mission': r['mission'], 'arch': sys.argv[1], 'rtf_requested': r['rtf_requested'], 'rtf_achieved': r['rtf_achieved'], 'success': r['success'], 'reason': r['reason'], 'run': sys.argv[3]}))" $$arch $$out.log $$out; \
	done

clean:
	rm -rf $(VENV) runs .pytest_cache
