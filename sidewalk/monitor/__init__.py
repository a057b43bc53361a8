"""The NAVIGATION MONITOR (seed §2.3.8): a live web page of a run, fed by the CODGER or EDDIE adapter or a recording."""

from sidewalk.monitor.errors import MonitorError, PortInUseError
from sidewalk.monitor.model import SECTIONS, MonitorModel
from sidewalk.monitor.server import MonitorServer, check_port

__all__ = ["MonitorError", "PortInUseError", "SECTIONS", "MonitorModel", "MonitorServer", "check_port"]
