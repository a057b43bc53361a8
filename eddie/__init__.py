"""The EDDIE variant (seed: Navlab 1990 §1.2.3, §2.5, ch. 3): point-to-point links, controller-held position, annotated maps.

`toolkit` (point-to-point links), `messages` (the message types), `annotated_map` and `missions` (the
annotation database, triggers, missions compiled into annotations); the processes, each run with
`python -m eddie.<name>`: `controller` (the integrated controller), `navigator` (world←local from
fixes), `map_manager`, `mission_service`, `road_following`, `landmark_matching`, `obstacle_stop`
(`modules` holds what these share). Nothing here imports `blackboard` or `codger`.
"""

__all__: list[str] = []
