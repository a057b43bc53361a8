"""Lines of glue: the code an architecture needs to wire its algorithms together, counted by rule.

The rule, applied to the files an architecture's processes reach by static imports from its
entry points (the `__main__.py` of each process its plans run, `sidewalk.processes`: `codger.<name>`
for CODGER, `eddie.<name>` for EDDIE; both reach the shared library `modules/` and the runtime
`runtime/`, CODGER the blackboard), `wire/` excluded (the transport both stand on):
- a file is *substrate* if it imports the transport of `wire` itself (`TRANSPORT`: sessions, keys,
  network flags, health — not its geometry or message types): the blackboard node and client, the
  module runtime; EDDIE's toolkit;
- a file is *glue* if it is substrate, or imports a substrate file (module mains, services, the
  code that posts, monitors, sends and receives);
- the rest is *algorithm* (segmentation, planners, filters, trackers: plain functions on data),
  which both architectures can share.
Lines are logical source lines: not blank, not only a comment, not part of a docstring.
"""

from __future__ import annotations

import ast
import io
import tokenize
from pathlib import Path
from typing import Sequence

from pydantic import BaseModel, ConfigDict

from sidewalk.processes import CODGER_PROCESSES, EDDIE_PROCESSES

__all__ = ["GlueCount", "count_glue", "logical_lines", "PACKAGES", "ENTRY_POINTS", "TRANSPORT"]

#: architecture → the packages its processes can reach.
PACKAGES: dict[str, tuple[str, ...]] = {"codger": ("codger", "modules", "runtime", "blackboard"),
                                        "eddie": ("eddie", "modules", "runtime")}
#: architecture → its processes' packages (each entered at its `__main__`)
ENTRY_POINTS: dict[str, tuple[str, ...]] = {"codger": tuple(CODGER_PROCESSES.values()), "eddie": tuple(EDDIE_PROCESSES.values())}

#: The transport modules of `wire` (importing one makes a file substrate).
TRANSPORT = ("wire.session", "wire.aio", "wire.keys", "wire.network", "wire.flags", "wire.router", "wire.health", "wire.ports")


class GlueCount(BaseModel):
    """An architecture's code by the rule above: files and logical lines [lines] per kind."""

    model_config = ConfigDict(frozen=True)

    architecture: str
    present: bool
    glue_lines: int = 0
    glue_files: int = 0
    substrate_lines: int = 0
    algorithm_lines: int = 0
    algorithm_files: int = 0
    glue_by_file: dict[str, int] = {}
    algorithm_by_file: dict[str, int] = {}


def logical_lines(source: str) -> int:
    """Return the logical lines of Python source: not blank, not only a comment, not in a docstring."""
    try:
        tree = ast.parse(source)
    except SyntaxError:
        return 0
    doc: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)) and node.body:
            first = node.body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant) and isinstance(first.value.value, str):
                doc.update(range(first.lineno, (first.end_lineno or first.lineno) + 1))
    code: set[int] = set()
    for tok in tokenize.generate_tokens(io.StringIO(source).readline):
        if tok.type in (tokenize.COMMENT, tokenize.NL, tokenize.NEWLINE, tokenize.INDENT, tokenize.DEDENT, tokenize.ENDMARKER):
            continue
        code.update(range(tok.start[0], tok.end[0] + 1))
    return len(code - doc)


def _module_of(root: Path, path: Path) -> str:
    rel = path.relative_to(root).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(tree: ast.AST, module: str, is_pkg: bool) -> set[str]:
    """Return the dotted names a module imports (relative imports resolved)."""
    out: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                pkg = module.split(".") if is_pkg else module.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join([*pkg, base] if base else pkg)
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def count_glue(root: Path, architecture: str, packages: Sequence[str] | None = None) -> GlueCount:
    """Count an architecture's glue and algorithm lines under the source tree `root` (see the module's rule).

    Entered at its processes' `__main__` (`ENTRY_POINTS`); an architecture not there at every `__main__.py` of `packages`.
    """
    pkgs = tuple(packages or PACKAGES[architecture])
    files: dict[str, Path] = {}
    for p in pkgs:
        for f in sorted((root / p).rglob("*.py")) if (root / p).is_dir() else []:
            files[_module_of(root, f)] = f
    parsed = {m: ast.parse(f.read_text()) for m, f in files.items()}
    deps: dict[str, set[str]] = {}
    wire_users: set[str] = set()
    for m, tree in parsed.items():
        names = _imports(tree, m, files[m].name == "__init__.py")
        if any(n == t or n.startswith(t + ".") for n in names for t in TRANSPORT):
            wire_users.add(m)
        # `from a.b import c` names a.b (a module) and a.b.c (a module or a name in a.b); a package's __init__ is a
        # dependency only when it is imported itself (`from a import x`), not because a sibling was (a file is glue
        # by what it imports itself: importing a.b runs a/__init__.py, which is reached but not what a.b uses)
        deps[m] = {n for n in names if n in files} | {n.rsplit(".", 1)[0] for n in names
                                                      if n not in files and n.rsplit(".", 1)[0] in files}
    mains = [m for m, f in files.items() if f.name == "__main__.py"]
    entries = [m for m in mains if m.removesuffix(".__main__") in ENTRY_POINTS[architecture]] if architecture in ENTRY_POINTS else mains
    reached: set[str] = set()
    todo = list(entries)
    while todo:
        m = todo.pop()
        if m in reached:
            continue
        reached.add(m)
        todo.extend(deps.get(m, ()) - reached)
        parent = m.rsplit(".", 1)[0] if "." in m else None
        if parent in files and parent not in reached:
            todo.append(parent)  # importing a.b runs a/__init__.py
    if not entries:
        return GlueCount(architecture=architecture, present=False)
    substrate = reached & wire_users
    glue = substrate | {m for m in reached if deps.get(m, set()) & substrate}
    lines = {m: logical_lines(files[m].read_text()) for m in reached}
    algo = reached - glue
    return GlueCount(
        architecture=architecture, present=True,
        glue_lines=sum(lines[m] for m in glue), glue_files=len(glue),
        substrate_lines=sum(lines[m] for m in substrate),
        algorithm_lines=sum(lines[m] for m in algo), algorithm_files=len(algo),
        glue_by_file={str(files[m].relative_to(root)): lines[m] for m in sorted(glue)},
        algorithm_by_file={str(files[m].relative_to(root)): lines[m] for m in sorted(algo)},
    )
