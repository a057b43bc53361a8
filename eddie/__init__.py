"""The EDDIE variant (seed: Navlab 1990 §1.2.3, §2.5, ch. 3): point-to-point links, controller-held position, annotated maps.

`toolkit` (links, module start-up and monitoring), `controller` (the integrated controller),
`navigator` (world←local from fixes), `messages` (the message types). Nothing here imports `blackboard`.
"""

__all__: list[str] = []
