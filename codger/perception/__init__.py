"""PERCEPTION on the blackboard (seed §3): driving units in, perception results out; `python -m codger.perception`."""

from codger.perception.module import PerceptionConfig, PerceptionModule

__all__ = ["PerceptionConfig", "PerceptionModule"]
