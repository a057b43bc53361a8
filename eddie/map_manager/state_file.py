"""The map manager's state on disk, so a manager killed and started again neither refires nor misses triggers.

The seed's annotations carry a `used` flag; a manager that starts afresh from the annotated map file
has every flag cleared and no idea where the vehicle was, so the triggers the vehicle crossed while
it was down are lost (a dead-reckoned intersection whose exit trigger never comes leaves vision
asleep for good). With `--state FILE` the manager writes, atomically (a temporary file, then rename),
the ids of the used annotations and where the vehicle was in `local` with the controller's odometer
[m] — on every trigger event and at least every `SAVE_EVERY_S` [s] sim. Started again with the file
there, it takes the flags back and walks the path the controller recorded between that odometer
reading and the present (`MapManagerModule`): the triggers crossed meanwhile fire then, once.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from eddie.errors import EddieError

__all__ = ["ManagerState", "StateFileError", "SAVE_EVERY_S", "load_state", "save_state"]

#: the longest the saved position lags the vehicle [s] sim (a trigger event saves at once)
SAVE_EVERY_S = 1.0


class StateFileError(EddieError, ValueError):
    """The state file cannot be read as a map manager's state of this annotated map (the message names the file)."""


class ManagerState(BaseModel):
    """What a map manager needs to go on after a restart: its map, the used flags, the vehicle's last position."""

    model_config = ConfigDict(frozen=True, extra="forbid")

    #: the annotated map file the state belongs to (its name; a state of another map is refused)
    annotated_map: str
    #: the annotations whose `used` flag is set
    used: tuple[str, ...] = ()
    #: the controller's odometer [m] at the vehicle's last position
    odometer: float = Field(ge=0.0)
    #: the vehicle's last position (x, y) [m] in `local`
    x: float
    y: float
    #: sim time [s] of that position
    stamp: float


def save_state(path: str | Path, state: ManagerState) -> None:
    """Write `state` to `path` atomically (a reader sees the old file or the new one, never half of one)."""
    p = Path(path)
    tmp = p.with_name(p.name + ".tmp")
    tmp.write_text(state.model_dump_json())
    os.replace(tmp, p)


def load_state(path: str | Path, *, annotated_map: str, known: set[str]) -> ManagerState | None:
    """Return the state saved at `path` (None: no file), checked against the map's name and annotation ids `known`."""
    p = Path(path)
    try:
        text = p.read_text()
    except FileNotFoundError:
        return None
    try:
        state = ManagerState.model_validate(json.loads(text))
    except json.JSONDecodeError as exc:
        raise StateFileError(f"{p}: not JSON (line {exc.lineno}, column {exc.colno}: {exc.msg}); delete it to start afresh") from None
    except ValidationError as exc:
        err = exc.errors()[0]
        where = ".".join(str(x) for x in err["loc"]) or "(top)"
        raise StateFileError(f"{p}: {where}: {err['msg']}; delete it to start afresh") from None
    if state.annotated_map != annotated_map:
        raise StateFileError(f"{p}: the state of annotated map {state.annotated_map!r}, not {annotated_map!r}; "
                             "delete it to start afresh")
    unknown = sorted(set(state.used) - known)
    if unknown:
        raise StateFileError(f"{p}: used annotations not in {annotated_map!r}: {', '.join(unknown[:5])}; delete it to start afresh")
    return state
