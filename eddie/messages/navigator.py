"""Messages of the navigator: position fixes in, world←local out (pushed on `world_from_local`, or answered on request).

A fix is measured at sim time `stamp` [s]; it carries the controller's `local` pose the sender used at
that time (`local`), since the controller keeps no pose history. Without it the navigator takes the
pose from its own short buffer of the controller's `state` stream.
"""

from __future__ import annotations

from pydantic import Field

from eddie.toolkit.message import Finite, Message, message_type
from wire.se2 import PoseFields

__all__ = ["LocalPose", "PointFixMessage", "LineFixMessage", "WorldFromLocal", "WorldFromLocalQuery"]


_F = Finite


class LocalPose(PoseFields, Message):
    """The controller's local←vehicle pose at a fix's time: x, y [m], yaw [rad] in `local`."""

    x: _F
    y: _F
    yaw: _F


@message_type("navigator.point_fix")
class PointFixMessage(PoseFields, Message):
    """A full fix: world←vehicle x, y [m], yaw [rad] at sim time `stamp` [s], with standard deviations [m], [rad]."""

    stamp: float = Field(ge=0.0)
    x: _F
    y: _F
    yaw: _F
    sigma_xy: float = Field(0.3, gt=0.0)
    sigma_yaw: float = Field(0.05, gt=0.0)
    local: LocalPose | None = None
    source: str = ""


@message_type("navigator.line_fix")
class LineFixMessage(Message):
    """A line fix: the vehicle lies on the `world` line through (x, y) [m] with direction `angle` [rad] at `stamp` [s]."""

    stamp: float = Field(ge=0.0)
    x: _F
    y: _F
    angle: _F
    sigma_cross: float = Field(0.3, gt=0.0)
    yaw: _F | None = None
    sigma_yaw: float | None = Field(None, gt=0.0)
    local: LocalPose | None = None
    source: str = ""


@message_type("navigator.world_from_local")
class WorldFromLocal(PoseFields, Message):
    """The transform world←local: x, y [m], yaw [rad], valid from sim time `stamp` [s]; fixes used so far."""

    stamp: float
    x: float
    y: float
    yaw: float
    fixes_used: int = 0


@message_type("navigator.world_from_local_query")
class WorldFromLocalQuery(Message):
    """Ask the navigator for world←local now."""
