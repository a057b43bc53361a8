"""The MAP NAVIGATOR on the blackboard (seed §2.3.2): steps → routes → route segments; `python -m codger.map_navigator`."""

from codger.map_navigator.service import MapNavigator, ServiceOptions

__all__ = ["MapNavigator", "ServiceOptions"]
