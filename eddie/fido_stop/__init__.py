"""FIDO obstacle stop (EDDIE): FIDO's stereo obstacle features along the controller's path, stop and hold; `python -m eddie.fido_stop`."""

from eddie.fido_stop.fido_stop import FidoStop, FidoStopError

__all__ = ["FidoStop", "FidoStopError"]
