"""Blackboard operations: every request a client sends and the node handles, as frozen models.

One definition serves both ends: the client builds these models and sends their wire form
(`wire()`: msgpack, or JSON from a person's tool); the node validates every request once with
`parse_write` / `parse_request` and answers a failure with a typed error naming what is wrong
(`bad_request`, `invalid_token` or `bad_spec`). Writes (`PostOp`, `UpdateOp`, `DeleteOp`,
`PoseOp`, `StaticOp`) are told apart by their `op` field (absent = post); they travel in
batches (`bb/write/<client>`, `bb/batch`) or one at a time (`bb/post|update|delete`). Reads and
admin requests: `RetrieveRequest`, `LookupRequest`, `MonitorRegister` / `MonitorCancel`,
`FramesRequest`, `StatsRequest`. Times are sim time [s]; poses are [x [m], y [m], yaw [rad]] of
`child` in `parent`. The wire form is documented in docs/keys.md.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, ClassVar, Literal, Union

from pydantic import AllowInfNan, BaseModel, ConfigDict, Field, Strict, StringConstraints, ValidationError

from blackboard.errors import BadRequestError, BadSpecError, BlackboardError, InvalidTokenError
from blackboard.spec import Spec

__all__ = [
    "FrameName",
    "PostOp",
    "UpdateOp",
    "DeleteOp",
    "PoseOp",
    "StaticOp",
    "WriteOp",
    "RetrieveRequest",
    "LookupRequest",
    "MonitorRegister",
    "MonitorCancel",
    "MonitorRequest",
    "FramesRequest",
    "StatsRequest",
    "parse_write",
    "plain_post",
    "parse_monitor",
]

#: a frame name: 1-128 letters, digits, '_', '-', '.'
FrameName = Annotated[str, Strict(), StringConstraints(pattern=r"^[A-Za-z0-9_.\-]{1,128}$")]
#: a client or monitor id: 1-64 letters, digits, '_', '-'
_Ident = Annotated[str, Strict(), StringConstraints(pattern=r"^[A-Za-z0-9_\-]{1,64}$")]
#: a finite real number (not a bool, not a numeric string)
_Finite = Annotated[float, Strict(), AllowInfNan(False)]
_Str = Annotated[str, Strict()]
_Int = Annotated[int, Strict()]
_Pose3 = tuple[_Finite, _Finite, _Finite]

_set = object.__setattr__


class _Request(BaseModel):
    """A request: validated once on the node; built by the client from already-typed values."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    #: the error a validation failure raises, unless `_field_errors` names another for the field
    _error: ClassVar[type[BlackboardError]] = BadRequestError
    _field_errors: ClassVar[dict[str, type[BlackboardError]]] = {}
    _what: ClassVar[str] = "request"

    @classmethod
    def trusted(cls, fields: dict[str, Any], fields_set: set[str] | None = None) -> Any:
        """Build an instance from values the caller's own types guarantee (the node validates it again).

        `fields` must hold every field (defaults included); `fields_set` names the ones given
        (default: all), which `wire()` sends.
        """
        obj = cls.__new__(cls)
        _set(obj, "__dict__", fields)
        _set(obj, "__pydantic_fields_set__", set(fields) if fields_set is None else fields_set)
        _set(obj, "__pydantic_extra__", None)
        _set(obj, "__pydantic_private__", None)
        return obj

    def wire(self) -> dict[str, Any]:
        """Return the wire object: the fields given (JSON-able)."""
        return self.model_dump(mode="json", include=self.__pydantic_fields_set__)

    @classmethod
    def parse(cls, obj: object) -> Any:
        """Validate a decoded wire object; raise the typed error naming what is wrong."""
        try:
            return cls.__pydantic_validator__.validate_python(obj)
        except ValidationError as exc:
            raise cls._typed_error(exc) from None
        except RecursionError:
            raise cls._error(f"bad {cls._what}: nested too deeply") from None

    @classmethod
    def _typed_error(cls, exc: ValidationError) -> BlackboardError:
        errs = exc.errors(include_url=False, include_input=False)
        parts = []
        err: type[BlackboardError] = cls._error
        for e in errs[:5]:
            loc = e.get("loc", ())
            if loc and loc[0] in cls._field_errors:
                err = cls._field_errors[loc[0]]
            where = ".".join(str(p) for p in loc) or "(root)"
            desc = cls.model_fields[loc[0]].description if loc and loc[0] in cls.model_fields else None
            parts.append(f"{where}{f' ({desc})' if desc else ''}: {e.get('msg')}")
        if errs and errs[0].get("type") == "model_type" and not errs[0].get("loc"):
            return BadRequestError(f"a {cls._what} must be an object")
        return err(f"bad {cls._what}: " + "; ".join(parts))


# ---------------------------------------------------------------------------------------- writes
class _Write(_Request):
    """A write: a bad field is an invalid token unless it is the operation itself."""

    _error: ClassVar[type[BlackboardError]] = InvalidTokenError
    _field_errors: ClassVar[dict[str, type[BlackboardError]]] = {"op": BadRequestError}


class PostOp(_Write):
    """Post a token of registered `type` with `attrs` at `stamp` [s], its geometry [m] in `frame`.

    `reply="id"` answers just the new id instead of the whole token.
    """

    # strict throughout (no list-to-tuple fields here): the cheapest validation on the hot path
    model_config = ConfigDict(frozen=True, extra="forbid", strict=True)
    _what: ClassVar[str] = "post operation"

    op: Literal["post"] = "post"
    type: _Str = Field(description="a registered token type")
    #: an object, checked against the type's model by the node's registry (the type decides its fields)
    attrs: Any = Field(default_factory=dict, description="an object, validated against the type's model")
    frame: FrameName = "world"
    stamp: _Finite = Field(description="sim time [s]")
    source: Annotated[str, Strict(), StringConstraints(max_length=128)] = ""
    #: a wire geometry object, checked (and its validity tested) by blackboard.geometry
    geometry: Any = Field(None, description="wire geometry [m]: point, polyline or polygon")
    reply: Literal["id"] | None = None

    def wire(self) -> dict[str, Any]:
        """Return the wire object (every field)."""
        return self.__dict__


class UpdateOp(_Write):
    """Replace a token's attrs / geometry / stamp / frame if it is still at `expected_version` (CAS).

    A field not given keeps its value; `geometry` given as None removes the geometry.
    """

    _what: ClassVar[str] = "update operation"
    _field_errors: ClassVar[dict[str, type[BlackboardError]]] = {k: BadRequestError for k in ("op", "id", "expected_version")}

    op: Literal["update"] = "update"
    id: _Str
    expected_version: _Int = Field(description="compare-and-set: the version the writer last saw")
    attrs: dict[str, Any] | None = None
    frame: FrameName | None = None
    stamp: _Finite | None = Field(None, description="sim time [s]")
    geometry: dict[str, Any] | None = Field(None, description="wire geometry [m]; given as null: none")

    @classmethod
    def _typed_error(cls, exc: ValidationError) -> BlackboardError:
        if any(e.get("type") == "missing" and e.get("loc") == ("expected_version",) for e in exc.errors()):
            return BadRequestError("update needs expected_version (compare-and-set)")
        return super()._typed_error(exc)


class DeleteOp(_Write):
    """Delete a token (only if at `expected_version`, when given)."""

    _what: ClassVar[str] = "delete operation"
    _error: ClassVar[type[BlackboardError]] = BadRequestError

    op: Literal["delete"] = "delete"
    id: _Str
    expected_version: _Int | None = None


class PoseOp(_Write):
    """Record `child`'s pose in `parent` at `stamp` [s]; `hold` [s] keeps the newest valid that long (None: forever)."""

    _what: ClassVar[str] = "pose operation"

    op: Literal["pose"] = "pose"
    parent: FrameName
    child: FrameName
    pose: _Pose3 = Field(description="[x [m], y [m], yaw [rad]]")
    stamp: _Finite = Field(description="sim time [s]")
    hold: Annotated[float, Strict(), Field(ge=0.0)] | None = Field(0.0, description="[s] ≥ 0, or null: forever")

    def wire(self) -> dict[str, Any]:
        """Return the wire object (every field)."""
        return self.__dict__


class StaticOp(_Write):
    """Fix `child` in `parent` for all times (e.g. a sensor on the vehicle)."""

    _what: ClassVar[str] = "static operation"

    op: Literal["static"] = "static"
    parent: FrameName
    child: FrameName
    pose: _Pose3 = Field(description="[x [m], y [m], yaw [rad]]")


_POST_KEYS = frozenset(PostOp.model_fields)
_FRAME_NAME = re.compile(r"[A-Za-z0-9_.\-]{1,128}").fullmatch  # FrameName's pattern, anchored at both ends as there


def plain_post(obj: object) -> tuple[str, Any, str, float, str, Any, str | None] | None:
    """Return (type, attrs, frame, stamp [s], source, geometry, reply) of a post operation in its
    common form — a dict of PostOp's fields only, each of its exact type — or None for any other
    input, which `parse_write` then validates (and answers with the typed error, if any).

    Every dict this accepts PostOp accepts with the same values; it saves building the model
    for each token of a batch.
    """
    if type(obj) is not dict or not _POST_KEYS.issuperset(obj):
        return None
    get = obj.get
    op, typ, frame, stamp, source, reply = get("op", "post"), get("type"), get("frame", "world"), get("stamp"), get("source", ""), get("reply")
    if (type(op) is str and op == "post" and type(typ) is str and type(stamp) is float and math.isfinite(stamp)
            and type(frame) is str and _FRAME_NAME(frame) is not None and type(source) is str and len(source) <= 128
            and (reply is None or (type(reply) is str and reply == "id"))):
        attrs = obj["attrs"] if "attrs" in obj else {}
        return typ, attrs, frame, stamp, source, get("geometry"), reply
    return None


WriteOp = Union[PostOp, UpdateOp, DeleteOp, PoseOp, StaticOp]
_WRITES: dict[Any, type[_Write]] = {"post": PostOp, "update": UpdateOp, "delete": DeleteOp, "pose": PoseOp, "static": StaticOp}
_WRITE_VALIDATORS = {k: (cls, cls.__pydantic_validator__.validate_python) for k, cls in _WRITES.items()}


def parse_write(obj: object) -> WriteOp:
    """Validate one write operation (a decoded wire object or a write model); raise the typed error."""
    if type(obj) is not dict:
        if isinstance(obj, (PostOp, UpdateOp, DeleteOp, PoseOp, StaticOp)):
            return obj
        raise BadRequestError(f"an operation must be an object, got {type(obj).__name__}")
    kind = obj.get("op", "post")
    entry = _WRITE_VALIDATORS.get(kind) if isinstance(kind, str) else None
    if entry is None:
        raise BadRequestError(f"unknown operation {kind!r} (post, update, delete, pose, static)"[:200])
    try:
        return entry[1](obj)
    except ValidationError as exc:
        raise entry[0]._typed_error(exc) from None


# ----------------------------------------------------------------------------------------- reads
class RetrieveRequest(_Request):
    """Retrieve the tokens matching `spec`; geometry expressed in `frame` at `frame_stamp` [s] if given.

    On the wire the payload is the spec itself and the frame travels as selector parameters
    `?frame=F;stamp=S` (a JSON tool may also send `{"spec", "frame", "frame_stamp"}`).
    """

    _what: ClassVar[str] = "retrieve request"
    _error: ClassVar[type[BlackboardError]] = BadSpecError

    spec: Spec = Spec()
    frame: FrameName | None = None
    frame_stamp: _Finite | None = Field(None, description="sim time [s]; None: each token's own stamp")

    def selector_parameters(self) -> str:
        """Return the selector parameters for `frame` and `frame_stamp` ('' when neither is set)."""
        params = []
        if self.frame is not None:
            params.append(f"frame={self.frame}")
        if self.frame_stamp is not None:
            params.append(f"stamp={self.frame_stamp!r}")
        return ";".join(params)

    @classmethod
    def from_wire(cls, body: object, params: dict[str, str]) -> "RetrieveRequest":
        """Validate a retrieve payload (the spec, or the envelope) with selector `params`."""
        req: dict[str, Any] = {}
        if params.get("frame"):
            req["frame"] = params["frame"]
        if params.get("stamp"):
            try:
                req["frame_stamp"] = float(params["stamp"])
            except ValueError:
                raise BadRequestError(f"stamp parameter {params['stamp']!r} is not a number") from None
            if not math.isfinite(req["frame_stamp"]):
                raise BadSpecError(f"output frame stamp {params['stamp']!r} must be a finite number [s]")
        if type(body) is dict and "spec" in body and set(body) <= {"spec", "frame", "frame_stamp"}:
            req.update(body)
        else:
            if not isinstance(body, dict):
                raise BadSpecError(f"spec must be an object, got {type(body).__name__}")
            req["spec"] = body
        return cls.parse(req)


class LookupRequest(_Request):
    """Look up T_{target@target_stamp ← source@source_stamp}; a None stamp means the newest pose."""

    _what: ClassVar[str] = "lookup request"
    _error: ClassVar[type[BlackboardError]] = InvalidTokenError

    target: FrameName
    target_stamp: _Finite | None = Field(None, description="sim time [s]")
    source: FrameName
    source_stamp: _Finite | None = Field(None, description="sim time [s]")

    def wire(self) -> dict[str, Any]:
        """Return the wire object (every field)."""
        return self.__dict__


class MonitorRegister(_Request):
    """Register (or replace) monitor `mid` of `client` on `spec`; events arrive on `bb/to/<client>`."""

    _what: ClassVar[str] = "monitor request"
    _field_errors: ClassVar[dict[str, type[BlackboardError]]] = {"spec": BadSpecError}

    client: _Ident
    mid: _Ident
    spec: Spec
    cancel: Literal[False] = False


class MonitorCancel(_Request):
    """Drop monitor `mid` of `client`."""

    _what: ClassVar[str] = "monitor request"

    client: _Ident
    mid: _Ident
    cancel: Literal[True]


MonitorRequest = Union[MonitorRegister, MonitorCancel]


class FramesRequest(_Request):
    """List the frame tree (the payload is empty or `{}`)."""

    _what: ClassVar[str] = "frames request"


class StatsRequest(_Request):
    """Read the node's counters (the payload is empty or `{}`)."""

    _what: ClassVar[str] = "stats request"


def parse_monitor(obj: object) -> MonitorRequest:
    """Validate a decoded monitor request: a cancel when `cancel` is true, else a registration."""
    if type(obj) is not dict:
        raise BadRequestError("monitor request must be an object {client, mid, spec} or {client, mid, cancel}")
    return MonitorCancel.parse(obj) if obj.get("cancel") else MonitorRegister.parse(obj)
