"""The layout DESIGN.md asks for: one file imports zenoh, modules/ and eddie/ never reach the simulator."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("wire", "blackboard", "modules", "vehicle_sim", "codger", "eddie", "runtime", "sidewalk", "bench")


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
    return out


def _sources(*packages: str) -> list[Path]:
    return [p for pkg in packages for p in sorted((REPO / pkg).rglob("*.py"))]


def test_exactly_one_source_file_imports_zenoh() -> None:
    users = [p.relative_to(REPO).as_posix() for p in _sources(*PACKAGES)
             if any(m == "zenoh" or m.startswith("zenoh.") for m in _imports(p))]
    assert users == ["wire/session.py"]


def test_modules_and_eddie_import_nothing_from_the_simulator() -> None:
    bad = {p.relative_to(REPO).as_posix(): sorted(m for m in _imports(p) if m.split(".")[0] in ("vehicle_sim", "sidewalk"))
           for p in _sources("modules", "eddie")}
    assert {k: v for k, v in bad.items() if v} == {}


def test_eddie_never_imports_the_blackboard() -> None:
    bad = [p.relative_to(REPO).as_posix() for p in _sources("eddie") if any(m.split(".")[0] == "blackboard" for m in _imports(p))]
    assert bad == []


def test_wire_depends_on_nothing_of_ours() -> None:
    ours = set(PACKAGES) - {"wire"}
    bad = {p.relative_to(REPO).as_posix(): sorted(m for m in _imports(p) if m.split(".")[0] in ours) for p in _sources("wire")}
    assert {k: v for k, v in bad.items() if v} == {}


def test_the_simulator_and_the_blackboard_do_not_import_the_composition_root() -> None:
    bad = {p.relative_to(REPO).as_posix(): sorted(m for m in _imports(p) if m.split(".")[0] in ("sidewalk", "modules", "eddie"))
           for p in _sources("vehicle_sim", "blackboard")}
    assert {k: v for k, v in bad.items() if v} == {}


def _error_classes(package: str) -> set[type]:
    """Import every module of `package`; return the exception classes defined in it."""
    import importlib
    import pkgutil

    pkg = importlib.import_module(package)
    mods = [pkg] + [importlib.import_module(m.name) for m in pkgutil.walk_packages(pkg.__path__, package + ".")
                    if not m.name.endswith("__main__")]
    return {c for m in mods for c in vars(m).values()
            if isinstance(c, type) and issubclass(c, BaseException) and c.__module__.split(".")[: len(package.split("."))] == package.split(".")}


#: (package, sub-packages left out: their errors get a root on another branch)
ERROR_PACKAGES = [
    ("wire", ()), ("blackboard", ()), ("sidewalk", ()), ("vehicle_sim", ()), ("modules", ()),
    ("modules.captain", ()), ("modules.map_navigator", ()), ("modules.pilot", ()), ("modules.helm", ()), ("runtime", ()),
    ("modules.perception", ()), ("modules.fido", ()), ("eddie", ()),
]


@pytest.mark.parametrize(("package", "left_out"), ERROR_PACKAGES)
def test_one_root_error_per_package(package: str, left_out: tuple[str, ...]) -> None:
    errors = {c for c in _error_classes(package) if not c.__module__.startswith(left_out)}
    roots = sorted(f"{c.__module__}.{c.__qualname__}" for c in errors if not any(b in errors for b in c.__mro__[1:]))
    assert len(roots) == 1, f"{package}: error roots {roots}"


def test_the_pilots_cores_are_libraries_without_a_blackboard() -> None:
    """EDDIE reuses the position estimator's filter and the local path planner: importing them pulls in no blackboard."""
    import subprocess
    import sys

    code = ("import sys, modules.pilot, modules.pilot.kalman, modules.pilot.planner, modules.pilot.local_path_constraints, "
            "modules.pilot.speed_profile, modules.pilot.segment, modules.pilot.driving_units; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('blackboard', 'zenoh') or m.startswith('modules.vocabulary')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=REPO, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"
