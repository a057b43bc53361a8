"""CODGER: the Sidewalk blackboard over Zenoh. Knows nothing about sidewalks."""

from blackboard.client import BlackboardClient, MonitorStream
from blackboard.errors import (
    BadRequestError,
    BadSpecError,
    BlackboardError,
    ExtrapolationError,
    FutureExtrapolationError,
    InvalidTokenError,
    NodeUnavailableError,
    NotFoundError,
    PastExtrapolationError,
    TokenTooLargeError,
    UnknownFrameError,
    UnknownTypeError,
    VersionConflictError,
)
from blackboard.frames import FrameTree
from blackboard.geometry import Point, Polygon, Polyline, Pose2D
from wire.keys import BlackboardKeys
from wire.network import DEFAULT_ENDPOINT, NetworkConfig
from blackboard.registry import TypeRegistry, default_registry, token_type
from blackboard.spec import AttrPredicate, Intersects, Near, Nearest, Spec, Within
from blackboard.token import MonitorEvent, Token

__all__ = [
    "DEFAULT_ENDPOINT",
    "NetworkConfig",
    "BlackboardClient",
    "MonitorStream",
    "BlackboardKeys",
    "Token",
    "MonitorEvent",
    "Spec",
    "AttrPredicate",
    "Near",
    "Within",
    "Intersects",
    "Nearest",
    "Point",
    "Polyline",
    "Polygon",
    "Pose2D",
    "FrameTree",
    "token_type",
    "TypeRegistry",
    "default_registry",
    "BlackboardError",
    "BadRequestError",
    "UnknownTypeError",
    "InvalidTokenError",
    "TokenTooLargeError",
    "BadSpecError",
    "VersionConflictError",
    "NotFoundError",
    "UnknownFrameError",
    "ExtrapolationError",
    "PastExtrapolationError",
    "FutureExtrapolationError",
    "NodeUnavailableError",
]
