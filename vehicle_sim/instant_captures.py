"""One render per sensor per sim instant: captures asked at the same sim time are rendered once and served to every asker.

Under EDDIE several modules ask the simulator for frames on their own (road following laser and
camera, obstacle stop the laser alone, landmark matching both): each used to be rendered anew, so an
instant two modules asked for was rendered twice (issue 39). A capture is a pure function of the
scene, the pose and the stamp — its noise is drawn from a generator seeded by the stamp, the laser's
draws first, then the camera's, then the stereo pair's (`vehicle_sim.sensors.capture`) — so a capture
already rendered at the same stamp *covers* a request when every part the request asks for was
rendered after the same draws, and the camera size asked is the same (every capture carries the camera
matrix of the size asked):

- the laser, if the capture has it (it draws first);
- the camera, if the capture has it and the laser was asked for alike;
- the stereo pair, if the capture has it at the same size and laser and camera were asked for alike.

A covering capture is served with the parts the request did not ask for left out; one that does not
cover is rendered and kept. Only the newest few instants are kept (`keep`).

A slow consumer may say an earlier instant will do (`CaptureRequest.max_age_s`): obstacle stop's scans at
2 Hz and landmark matching's frames every 2 s are then those road following had rendered at 5 Hz, when
it runs, at most that much older; each module pairs a frame with the pose at the frame's own stamp.
Only instants before the asker's are looked at, never another capture of its own instant that came
first: in lock-step which of two modules asking at one tick the simulator hears first is not fixed,
so that must not decide what either gets.
"""

from __future__ import annotations

import dataclasses
import threading
from collections import OrderedDict
from typing import Callable

from wire.capture import CaptureRequest, CaptureResult

__all__ = ["InstantCaptures", "covers", "restrict"]

_LASER = ("laser_code", "laser_range", "laser_valid", "laser_reflectance", "laser_xyz", "laser_labels",
          "laser_range_true", "laser_mixed")
_CAMERA = ("camera_image", "camera_labels")
_REGISTERED = ("colored_range", "colored_range_uv", "colored_range_valid")  # laser and camera together


def _has(result: CaptureResult, field: str) -> bool:
    return getattr(result, field, None) is not None


def covers(rendered_for: CaptureRequest, request: CaptureRequest) -> bool:
    """Return whether a capture rendered for `rendered_for` holds, bit for bit, every part `request` asks for."""
    lr, cr, sr = rendered_for.laser, rendered_for.camera, rendered_for.stereo
    if (request.camera_width, request.camera_height) != (rendered_for.camera_width, rendered_for.camera_height):
        return False  # every capture carries the camera's matrix for the size asked, the camera's image or not
    if request.laser and not lr:
        return False
    if request.camera and not (cr and request.laser == lr):
        return False
    if request.stereo and not (sr and request.laser == lr and request.camera == cr
                               and request.stereo_size == rendered_for.stereo_size):
        return False
    return True


def restrict(result: CaptureResult, request: CaptureRequest) -> CaptureResult:
    """Return `result` without the parts `request` did not ask for (as a capture of that request alone would be)."""
    drop: list[str] = []
    if not request.laser:
        drop += _LASER
    if not request.camera:
        drop += _CAMERA
    if not (request.laser and request.camera):
        drop += _REGISTERED
    if not request.stereo:
        drop += [f.name for f in dataclasses.fields(result) if f.name.startswith("stereo_") or f.name.startswith("T_vehicle_stereo")]
    drop = [f for f in drop if _has(result, f)]
    return dataclasses.replace(result, **{f: None for f in drop}) if drop else result


class InstantCaptures:
    """The captures of the newest `keep` sim instants, each rendered once per covering request (thread-safe)."""

    def __init__(self, keep: int = 4) -> None:
        self.keep = keep
        self._by_stamp: OrderedDict[float, list[tuple[CaptureRequest, CaptureResult]]] = OrderedDict()
        self._lock = threading.Lock()
        #: captures served from one rendered before (`older`: of an earlier instant), and captures rendered
        self.hits = 0
        self.older = 0
        self.renders = 0

    def get(self, stamp: float, request: CaptureRequest, render: Callable[[CaptureRequest], CaptureResult]) -> tuple[CaptureResult, bool]:
        """Return the capture of `request` at `stamp` [s sim] and whether it was rendered now (`render(request)`) or served again."""
        with self._lock:
            if request.max_age_s > 0.0:  # instants before this one first: those are complete, whoever asks first now
                for t in sorted((t for t in self._by_stamp if stamp - request.max_age_s - 1e-9 <= t < stamp), reverse=True):
                    for rendered_for, result in self._by_stamp[t]:
                        if covers(rendered_for, request):
                            self.hits += 1
                            self.older += 1
                            return restrict(result, request), False
            for rendered_for, result in self._by_stamp.get(stamp, ()):  # the same bits as a render now
                if covers(rendered_for, request):
                    self.hits += 1
                    return restrict(result, request), False
        result = render(request)
        with self._lock:
            self.renders += 1
            self._by_stamp.setdefault(stamp, []).append((request, result))
            self._by_stamp.move_to_end(stamp)
            while len(self._by_stamp) > self.keep:
                self._by_stamp.popitem(last=False)
        return result, True
