"""EDDIE's layout: nothing under `eddie` loads the blackboard, and every module declares `__all__`."""

from __future__ import annotations

import subprocess
import sys

from tests.modules._procs import ROOT

_PROBE = """
import importlib, pkgutil, sys
import eddie
names = [m.name for m in pkgutil.walk_packages(eddie.__path__, "eddie.")]
for n in names:
    importlib.import_module(n)
print(len(names))
print("blackboard" in sys.modules or any(k.startswith("blackboard.") for k in sys.modules))
print(",".join(n for n in names if not hasattr(sys.modules[n], "__all__")))
"""


def test_importing_every_eddie_module_loads_no_blackboard():
    out = subprocess.run([sys.executable, "-c", _PROBE], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    count, loaded, missing_all = out.stdout.splitlines()
    assert int(count) >= 8
    assert loaded == "False"
    assert missing_all == "", f"modules without __all__: {missing_all}"


def test_the_probe_can_fail_a_module_that_loads_the_blackboard():
    probe = "import sys, modules.vocabulary, blackboard; print('blackboard' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", probe], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert out.stdout.strip() == "True"
