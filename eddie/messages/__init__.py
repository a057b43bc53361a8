"""EDDIE's message types, one file per module that answers or receives them (controller, navigator, map manager…).

Importing this package imports every file in it, so every message type is registered and any
receiver can decode any EDDIE message.
"""

import importlib
import pkgutil

__all__: list[str] = []

for _m in pkgutil.iter_modules(__path__):
    importlib.import_module(f"{__name__}.{_m.name}")
