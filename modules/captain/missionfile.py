"""Mission files: parse and validate YAML (or JSON) missions; errors name the line and the field.

Schema (worlds/MISSIONS.md)::

    mission: campus-tour            # name (required)
    description: free text          # optional
    world: campus                   # optional: the world the mission is written for
    vehicle: terregator             # optional: terregator | navlab
    start: {x: 0, y: -28, yaw_deg: 90}   # optional: where the vehicle stands (world frame [m], [deg])
    steps:                          # required, at least one
      - name: to the quad           # optional (default "step N")
        destination: quad           # a place name, {place: NAME} or {x: X, y: Y[, off_road: true]} (world frame [m])
        constraints: [keep_right, avoid_stairs, {speed_limit: 1.0}]   # or a mapping
        trigger: {action: wait, seconds: 5}                            # or stop | continue | "wait 5"
        tolerance: 1.5              # optional: how close [m] the vehicle must truly get (default 1.5)
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable

import yaml
from pydantic import ValidationError

from modules.vocabulary import DEFAULT_TOLERANCE_M, Destination, Mission, MissionStart, MissionStepSpec, StepConstraints, Trigger
from modules.captain.errors import CaptainError
from wire.mission import ProblemWire, Rejection

__all__ = ["MissionProblem", "MissionFileError", "parse_mission", "load_mission", "rejection_from", "CONSTRAINT_NAMES",
           "MAX_MISSION_BYTES", "MAX_MISSION_STEPS", "MAX_MESSAGE_CHARS"]

#: The largest mission text accepted [bytes] (the campus tour is under 2 KB).
MAX_MISSION_BYTES = 256 * 1024
#: The most steps a mission may have.
MAX_MISSION_STEPS = 1000
#: A problem's message is cut to this many characters: an error never echoes a huge value back.
MAX_MESSAGE_CHARS = 200
#: At most this many problems are listed (and counted beyond).
_MAX_PROBLEMS = 20

#: Constraint names a mission may use.
CONSTRAINT_NAMES: tuple[str, ...] = ("keep_right", "keep_left", "avoid_stairs", "avoid_slope", "speed_limit")
_TOP_FIELDS = ("mission", "name", "description", "world", "vehicle", "start", "steps")
_STEP_FIELDS = ("name", "destination", "constraints", "trigger", "tolerance")
_VEHICLES = ("terregator", "navlab")
_ACTIONS = ("stop", "wait", "continue")


@dataclass(frozen=True)
class MissionProblem:
    """One thing wrong in a mission file: line and column (1-based, None if unknown), field path, what."""

    line: int | None
    column: int | None
    field: str
    message: str

    def __str__(self) -> str:
        where = f"line {self.line}, column {self.column}" if self.line is not None else "(no line)"
        return f"{where}: {self.field or '(top level)'}: {self.message}"

    def located(self, source: str) -> str:
        """Return "SOURCE:LINE:COL: FIELD: MESSAGE" (compiler style)."""
        where = f"{source}:{self.line}:{self.column}" if self.line is not None else source
        return f"{where}: {self.field or '(top level)'}: {self.message}"


class MissionFileError(CaptainError, ValueError):
    """A mission that cannot be used; names the source and, per problem, the line and field."""

    def __init__(self, source: str, problems: Iterable[MissionProblem]) -> None:
        self.source = source
        every = sorted(problems, key=lambda p: (p.line if p.line is not None else -1, p.column or 0))
        self.problems: tuple[MissionProblem, ...] = tuple(
            MissionProblem(p.line, p.column, p.field[:MAX_MESSAGE_CHARS], _cut(p.message)) for p in every[:_MAX_PROBLEMS])
        more = [f"  … and {len(every) - _MAX_PROBLEMS} more"] if len(every) > _MAX_PROBLEMS else []
        if len(every) == 1:  # one problem: one line
            super().__init__(self.problems[0].located(source))
        else:
            super().__init__("\n".join([f"{source}: invalid mission ({len(every)} problem(s))"]
                                       + [f"  {p.located(source)}" for p in self.problems] + more))


def rejection_from(exc: MissionFileError) -> Rejection:
    """Return the mission contract's rejection of an invalid mission (each problem with its line and field)."""
    return Rejection(
        error="invalid_mission", message=str(exc),
        problems=tuple(ProblemWire(line=p.line, column=p.column, field=p.field, message=p.message) for p in exc.problems),
    )


def _cut(text: str) -> str:
    """Return `text` cut to `MAX_MESSAGE_CHARS`, saying how much was left out."""
    if len(text) <= MAX_MESSAGE_CHARS:
        return text
    return f"{text[:MAX_MESSAGE_CHARS]}… ({len(text) - MAX_MESSAGE_CHARS} more characters)"


def _too_large(source: str, size: int) -> MissionFileError:
    return MissionFileError(source, [MissionProblem(None, None, "", f"{size} bytes is too large for a mission "
                                                    f"(the limit is {MAX_MISSION_BYTES} bytes)")])


class _Collector:
    def __init__(self) -> None:
        self.problems: list[MissionProblem] = []

    def add(self, node: yaml.Node | None, field: str, message: str) -> None:
        line = node.start_mark.line + 1 if node is not None else None
        col = node.start_mark.column + 1 if node is not None else None
        self.problems.append(MissionProblem(line, col, field, message))


class _Constructor(yaml.SafeLoader):
    pass


def _value(node: yaml.Node) -> Any:
    loader = _Constructor("")
    try:
        return loader.construct_object(node, deep=True)
    finally:
        loader.dispose()


def _mapping(node: yaml.Node, field: str, c: _Collector, allowed: tuple[str, ...]) -> dict[str, tuple[yaml.Node, yaml.Node]] | None:
    if not isinstance(node, yaml.MappingNode):
        c.add(node, field, f"must be a mapping (key: value), got {_kind(node)}")
        return None
    out: dict[str, tuple[yaml.Node, yaml.Node]] = {}
    for k, v in node.value:
        key = k.value if isinstance(k, yaml.ScalarNode) else None
        sub = f"{field}.{key}" if field else str(key)
        if key is None:
            c.add(k, field, "keys must be plain names")
        elif key in out:
            c.add(k, sub, "duplicate key")
        elif key not in allowed:
            c.add(k, sub, f"unknown field; expected one of {', '.join(allowed)}")
        else:
            out[key] = (k, v)
    return out


def _kind(node: yaml.Node) -> str:
    if isinstance(node, yaml.MappingNode):
        return "a mapping"
    if isinstance(node, yaml.SequenceNode):
        return "a list"
    v = _value(node)
    return "nothing (null)" if v is None else f"{type(v).__name__} {v!r}"


def _string(node: yaml.Node, field: str, c: _Collector) -> str | None:
    if not isinstance(node, yaml.ScalarNode):
        c.add(node, field, f"must be a string, got {_kind(node)}")
        return None
    v = _value(node)
    if v is None or (isinstance(v, str) and not v.strip()):
        c.add(node, field, "must be a non-empty string")
        return None
    return str(v)


def _number(node: yaml.Node, field: str, c: _Collector, *, positive: bool = False) -> float | None:
    v = _value(node) if isinstance(node, yaml.ScalarNode) else None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        c.add(node, field, f"must be a finite number, got {_kind(node)}")
        return None
    if positive and v <= 0:
        c.add(node, field, f"must be > 0, got {v!r}")
        return None
    return float(v)


def _destination(node: yaml.Node, field: str, c: _Collector) -> Destination | None:
    if isinstance(node, yaml.ScalarNode):
        name = _string(node, field, c)
        return Destination(place=name) if name is not None else None
    m = _mapping(node, field, c, ("place", "x", "y", "off_road"))
    if m is None:
        return None
    if "place" in m:
        if "x" in m or "y" in m or "off_road" in m:
            c.add(node, field, "give either place or x and y (with off_road), not both")
            return None
        name = _string(m["place"][1], f"{field}.place", c)
        return Destination(place=name) if name is not None else None
    if "x" not in m or "y" not in m:
        c.add(node, field, "needs place, or both x and y [m] (world frame)")
        return None
    x = _number(m["x"][1], f"{field}.x", c)
    y = _number(m["y"][1], f"{field}.y", c)
    off_road = False
    if "off_road" in m:
        v = _value(m["off_road"][1])
        if not isinstance(v, bool):
            c.add(m["off_road"][1], f"{field}.off_road", f"must be true or false, got {_kind(m['off_road'][1])}")
            return None
        off_road = v
    return Destination(xy=(x, y), off_road=off_road) if x is not None and y is not None else None


def _constraints(node: yaml.Node, field: str, c: _Collector) -> StepConstraints | None:
    items: list[tuple[str, yaml.Node, yaml.Node | None]] = []  # (name, name node, value node)
    if isinstance(node, yaml.SequenceNode):
        for i, item in enumerate(node.value):
            f = f"{field}[{i}]"
            if isinstance(item, yaml.ScalarNode):
                items.append((str(_value(item)), item, None))
            elif isinstance(item, yaml.MappingNode) and len(item.value) == 1:
                k, v = item.value[0]
                items.append((str(_value(k)), k, v))
            else:
                c.add(item, f, "must be a constraint name or a one-key mapping like {speed_limit: 1.0}")
    elif isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            items.append((str(_value(k)), k, v))
    elif isinstance(node, yaml.ScalarNode) and _value(node) is None:
        return StepConstraints()
    else:
        c.add(node, field, f"must be a list of constraint names or a mapping, got {_kind(node)}")
        return None
    keep: str | None = None
    flags: dict[str, Any] = {}
    seen: set[str] = set()
    ok = True
    for name, knode, vnode in items:
        f = f"{field}.{name}"
        if name not in CONSTRAINT_NAMES:
            c.add(knode, f, f"unknown constraint; expected one of {', '.join(CONSTRAINT_NAMES)}")
            ok = False
            continue
        if name in seen:
            c.add(knode, f, "given twice")
            ok = False
            continue
        seen.add(name)
        if name == "speed_limit":
            if vnode is None:
                c.add(knode, f, "needs a value in m/s, e.g. {speed_limit: 1.0}")
                ok = False
                continue
            v = _number(vnode, f, c, positive=True)
            if v is None:
                ok = False
            elif v > 20.0:
                c.add(vnode, f, f"{v} m/s is above 20 m/s; speed limits are in m/s")
                ok = False
            else:
                flags["speed_limit"] = v
            continue
        on = True
        if vnode is not None:
            val = _value(vnode) if isinstance(vnode, yaml.ScalarNode) else None
            if not isinstance(val, bool):
                c.add(vnode, f, f"must be true or false, got {_kind(vnode)}")
                ok = False
                continue
            on = val
        if not on:
            continue
        if name in ("keep_right", "keep_left"):
            side = name.removeprefix("keep_")
            if keep is not None and keep != side:
                c.add(knode, f, "keep_right and keep_left exclude each other")
                ok = False
                continue
            keep = side
        else:
            flags[name] = True
    if not ok:
        return None
    return StepConstraints(keep=keep, **flags)


_WAIT_RE = re.compile(r"^\s*wait\s+([0-9]*\.?[0-9]+)\s*s?\s*$")


def _trigger(node: yaml.Node, field: str, c: _Collector) -> Trigger | None:
    if isinstance(node, yaml.ScalarNode):
        text = str(_value(node)).strip()
        if text in ("stop", "continue"):
            return Trigger(action=text)  # type: ignore[arg-type]
        m = _WAIT_RE.match(text)
        if m and float(m.group(1)) > 0:
            return Trigger(action="wait", wait_s=float(m.group(1)))
        c.add(node, field, f"must be stop, continue, 'wait N' (seconds > 0) or {{action: ..., seconds: N}}, got {text!r}")
        return None
    m = _mapping(node, field, c, ("action", "seconds"))
    if m is None:
        return None
    if "action" not in m:
        c.add(node, f"{field}.action", "required field is missing")
        return None
    action = _string(m["action"][1], f"{field}.action", c)
    if action is None:
        return None
    if action not in _ACTIONS:
        c.add(m["action"][1], f"{field}.action", f"must be one of {', '.join(_ACTIONS)}, got {action!r}")
        return None
    if action == "wait":
        if "seconds" not in m:
            c.add(m["action"][1], f"{field}.seconds", "action wait needs seconds > 0 (sim time)")
            return None
        s = _number(m["seconds"][1], f"{field}.seconds", c, positive=True)
        return Trigger(action="wait", wait_s=s) if s is not None else None
    if "seconds" in m:
        c.add(m["seconds"][0], f"{field}.seconds", f"only meaningful with action wait, not {action}")
        return None
    return Trigger(action=action)  # type: ignore[arg-type]


def _start(node: yaml.Node, c: _Collector) -> MissionStart | None:
    m = _mapping(node, "start", c, ("x", "y", "yaw_deg"))
    if m is None:
        return None
    vals = {}
    for k in ("x", "y", "yaw_deg"):
        if k not in m:
            c.add(node, f"start.{k}", "required field is missing (start needs x, y [m] and yaw_deg [deg])")
            continue
        vals[k] = _number(m[k][1], f"start.{k}", c)
    if len(vals) < 3 or any(v is None for v in vals.values()):
        return None
    return MissionStart(**vals)


def _step(node: yaml.Node, index: int, c: _Collector) -> MissionStepSpec | None:
    field = f"steps[{index}]"
    m = _mapping(node, field, c, _STEP_FIELDS)
    if m is None:
        return None
    n_before = len(c.problems)
    name = _string(m["name"][1], f"{field}.name", c) if "name" in m else f"step {index + 1}"
    if "destination" not in m:
        c.add(node, f"{field}.destination", "required field is missing")
        dest = None
    else:
        dest = _destination(m["destination"][1], f"{field}.destination", c)
    cons = _constraints(m["constraints"][1], f"{field}.constraints", c) if "constraints" in m else StepConstraints()
    trig = _trigger(m["trigger"][1], f"{field}.trigger", c) if "trigger" in m else Trigger()
    tol = _number(m["tolerance"][1], f"{field}.tolerance", c, positive=True) if "tolerance" in m else DEFAULT_TOLERANCE_M
    if len(c.problems) > n_before or name is None or dest is None or cons is None or trig is None or tol is None:
        return None
    return MissionStepSpec(name=name, destination=dest, constraints=cons, trigger=trig, tolerance=tol)


def parse_mission(text: str | bytes, *, source: str = "<mission>", mission_id: str = "") -> Mission:
    """Parse and validate a mission (YAML or JSON text); raise MissionFileError naming lines and fields.

    `mission_id` is stored in the result (the CAPTAIN assigns it on acceptance).
    """
    if len(text) > MAX_MISSION_BYTES:
        raise _too_large(source, len(text.encode("utf-8", errors="replace")) if isinstance(text, str) else len(text))
    if isinstance(text, bytes):
        try:
            text = text.decode("utf-8")
        except UnicodeDecodeError as exc:
            raise MissionFileError(source, [MissionProblem(None, None, "", f"not UTF-8 text (a binary file?): byte {exc.start} is 0x{exc.object[exc.start]:02x}")]) from None
    if "\x00" in text:
        raise MissionFileError(source, [MissionProblem(None, None, "", "not text: it holds NUL bytes (a binary file?)")])
    try:
        root = yaml.compose(text, Loader=yaml.SafeLoader)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = mark.line + 1 if mark is not None else None
        col = mark.column + 1 if mark is not None else None
        raise MissionFileError(source, [MissionProblem(line, col, "", f"not valid YAML/JSON: {exc.problem or exc}")]) from None
    except yaml.YAMLError as exc:
        raise MissionFileError(source, [MissionProblem(None, None, "", f"not valid YAML/JSON: {exc}")]) from None
    c = _Collector()
    if root is None:
        raise MissionFileError(source, [MissionProblem(1, 1, "", "empty mission")])
    try:
        m = _mapping(root, "", c, _TOP_FIELDS)
    except yaml.YAMLError as exc:  # e.g. an unknown tag
        raise MissionFileError(source, [MissionProblem(None, None, "", f"not valid YAML: {exc}")]) from None
    if m is None:
        raise MissionFileError(source, c.problems)
    name: str | None = None
    if "mission" in m and "name" in m:
        c.add(m["name"][0], "name", "give the mission name once, as mission: NAME")
    key = "mission" if "mission" in m else "name" if "name" in m else None
    if key is None:
        c.add(root, "mission", "required field is missing (the mission name)")
    else:
        name = _string(m[key][1], key, c)
    desc = _string(m["description"][1], "description", c) if "description" in m else ""
    world = _string(m["world"][1], "world", c) if "world" in m else None
    vehicle = None
    if "vehicle" in m:
        vehicle = _string(m["vehicle"][1], "vehicle", c)
        if vehicle is not None and vehicle not in _VEHICLES:
            c.add(m["vehicle"][1], "vehicle", f"must be one of {', '.join(_VEHICLES)}, got {vehicle!r}")
            vehicle = None
    start = _start(m["start"][1], c) if "start" in m else None
    steps: list[MissionStepSpec | None] = []
    if "steps" not in m:
        c.add(root, "steps", "required field is missing (a list of at least one step)")
    else:
        snode = m["steps"][1]
        if not isinstance(snode, yaml.SequenceNode):
            c.add(snode, "steps", f"must be a list of steps, got {_kind(snode)}")
        elif not snode.value:
            c.add(snode, "steps", "needs at least one step")
        elif len(snode.value) > MAX_MISSION_STEPS:
            c.add(snode, "steps", f"{len(snode.value)} steps is too many (the limit is {MAX_MISSION_STEPS} steps)")
        else:
            steps = [_step(s, i, c) for i, s in enumerate(snode.value)]
    if c.problems:
        raise MissionFileError(source, c.problems)
    try:
        return Mission(mission_id=mission_id, name=name or "", description=desc or "", world=world, vehicle=vehicle,
                       start=start, steps=tuple(s for s in steps if s is not None))
    except ValidationError as exc:  # defensive: every field was checked above
        raise MissionFileError(source, [MissionProblem(None, None, ".".join(map(str, e["loc"])), e["msg"]) for e in exc.errors()]) from None


def load_mission(path: str | Path, *, mission_id: str = "") -> Mission:
    """Read and validate a mission file; raise MissionFileError (also for an unreadable file)."""
    p = Path(path)
    try:
        size = p.stat().st_size
        if size > MAX_MISSION_BYTES:
            raise _too_large(str(p), size)
        data = p.read_bytes()
    except OSError as exc:
        raise MissionFileError(str(p), [MissionProblem(None, None, "", f"cannot read file: {exc.strerror or exc}")]) from None
    return parse_mission(data, source=str(p), mission_id=mission_id)
