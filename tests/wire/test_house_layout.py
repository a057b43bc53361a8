"""The house of issue 42: a shared library, CODGER and EDDIE as equal rooms, one runtime, one seam, no circle."""

from __future__ import annotations

import ast
import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
#: the process entry points of both architectures (`python -m codger.<name>`, `python -m eddie.<name>`)
ENTRY_POINTS = sorted([*REPO.glob("codger/*/__main__.py"), *REPO.glob("eddie/*/__main__.py")])


def _imports(path: Path) -> set[str]:
    """Return every absolute module an import in `path` names, `from M import n` as M and M.n (function-level ones too)."""
    out: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.add(node.module)
            out.update(f"{node.module}.{a.name}" for a in node.names)
    return out


def _sources(*packages: str) -> list[Path]:
    return [p for pkg in packages for p in sorted((REPO / pkg).rglob("*.py"))]


def _bad(packages: tuple[str, ...], banned: tuple[str, ...]) -> dict[str, list[str]]:
    """Return, per file of `packages`, the imports that are `banned` modules or inside them."""
    out = {}
    for p in _sources(*packages):
        hit = sorted(m for m in _imports(p) if any(m == b or m.startswith(b + ".") for b in banned))
        if hit:
            out[p.relative_to(REPO).as_posix()] = hit
    return out


def test_the_library_imports_no_transport_and_neither_architecture() -> None:
    assert _bad(("modules",), ("blackboard", "zenoh", "wire.session", "wire.aio", "wire.flags", "runtime", "codger", "eddie",
                               "sidewalk", "vehicle_sim")) == {}


def test_codger_and_eddie_do_not_import_each_other() -> None:
    assert _bad(("codger",), ("eddie",)) == {}
    assert _bad(("eddie",), ("codger", "blackboard")) == {}


def test_the_runtime_depends_on_wire_alone() -> None:
    assert _bad(("runtime",), ("blackboard", "modules", "codger", "eddie", "sidewalk", "vehicle_sim", "bench")) == {}


def test_no_package_loads_parts_lazily_through_getattr() -> None:
    lazy = [p.relative_to(REPO).as_posix() for p in _sources("codger", "eddie", "modules", "runtime", "sidewalk", "wire", "blackboard")
            if any(isinstance(n, ast.FunctionDef) and n.name == "__getattr__" for n in ast.parse(p.read_text()).body)]
    assert lazy == []


def test_every_process_entry_point_runs_on_the_one_runtime_with_the_one_flag_helper() -> None:
    assert len(ENTRY_POINTS) >= 13  # six CODGER services, seven EDDIE modules
    for p in ENTRY_POINTS:
        names = _imports(p)
        where = p.relative_to(REPO).as_posix()
        assert {"runtime.run_module", "runtime.parse_module_args"} <= names, where
        # the parser comes from the one helper, or from another entry point's parser that does (FIDO's stop extends obstacle stop's)
        extends = {n.removesuffix(".build_parser") for n in names if n.endswith(".__main__.build_parser")}
        assert "runtime.module_parser" in names or any(
            "runtime.module_parser" in _imports(REPO / (e.replace(".", "/") + ".py")) for e in extends), where
    # no process builds its own parser: the flags come from runtime.flags
    own = [p.relative_to(REPO).as_posix() for p in _sources("codger", "eddie") if "ArgumentParser(" in p.read_text()]
    assert own == []


def test_one_supervisor_one_mission_contract_one_seam() -> None:
    defined: dict[str, list[str]] = {}
    for p in _sources("codger", "eddie", "modules", "runtime", "sidewalk", "wire"):
        for n in ast.parse(p.read_text()).body:
            if isinstance(n, ast.ClassDef) and n.name in ("Supervisor", "SubmitAccepted", "Rejection", "CancelRequest"):
                defined.setdefault(n.name, []).append(p.relative_to(REPO).as_posix())
    assert defined == {"Supervisor": ["sidewalk/supervisor.py"], "SubmitAccepted": ["wire/mission.py"],
                       "Rejection": ["wire/mission.py"], "CancelRequest": ["wire/mission.py"]}
    launcher = (REPO / "sidewalk" / "launcher.py").read_text()
    assert "arch ==" not in launcher and "eddie_run" not in launcher and "codger_run" not in launcher
    for arch in ("codger_run", "eddie_run"):  # an architecture knows the run's setup, never the launcher
        assert "sidewalk.launcher" not in _imports(REPO / "sidewalk" / f"{arch}.py"), arch


def test_one_mission_desk_for_both_mission_services() -> None:
    """The CAPTAIN and EDDIE's mission service take missions at the one desk: neither declares the contract's keys itself."""
    services = {"codger/captain/service.py", "eddie/mission_service/mission_service.py"}
    for where in services:
        assert "runtime.mission_desk.MissionDesk" in _imports(REPO / where), where
    declaring = sorted(p.relative_to(REPO).as_posix() for p in _sources("codger", "eddie", "modules", "runtime", "sidewalk")
                       if re.search(r"queryable\([^)]*(submit|cancel|status)", p.read_text()))
    assert declaring == ["runtime/mission_desk.py"]


def test_no_circle_between_our_modules() -> None:
    mods: dict[str, Path] = {}
    for p in _sources("sidewalk", "codger", "eddie", "modules", "runtime", "wire"):
        name = ".".join(p.relative_to(REPO).with_suffix("").parts)
        mods[name.removesuffix(".__init__")] = p
    graph = {m: {i for i in _imports(p) if i in mods and i != m} for m, p in mods.items()}
    # Tarjan's strongly connected components: a component of more than one module is a circle
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    circles: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while (w := stack.pop()) != v:
                comp.append(w)
            if comp:
                circles.append(sorted([v, *comp]))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    assert circles == []
