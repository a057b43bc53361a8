"""The layout DESIGN.md asks for: one file imports zenoh, modules/ and eddie/ never reach the simulator."""

from __future__ import annotations

import ast
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("wire", "blackboard", "modules", "vehicle_sim", "eddie", "sidewalk", "bench")


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
