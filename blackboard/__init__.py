"""CODGER: the Sidewalk blackboard over Zenoh. Knows nothing about sidewalks."""

from blackboard.network import DEFAULT_ENDPOINT, NetworkConfig

__all__ = ["DEFAULT_ENDPOINT", "NetworkConfig"]
