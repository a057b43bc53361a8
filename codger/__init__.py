"""CODGER's services: the Sidewalk modules as processes on the blackboard (seed: Sidewalk 1986 §2.3).

One sub-package per module, each run with `python -m codger.<name>`: `captain`, `map_navigator`,
`pilot`, `helm`, `perception`, `obstacles` (the OBSTACLE DETECTOR). Each is the blackboard-facing
glue around algorithms of the shared library (`modules/`), run by the one module runtime
(`runtime/`) with the blackboard client plugged in. Nothing here is imported by `eddie/`, nor
imports it.
"""

__all__: list[str] = []
