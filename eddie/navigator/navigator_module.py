"""The navigator as an EDDIE module: fixes in its inbox, world←local delivered as each subscriber chose.

Delivery (`deliver`, chosen at start-up from the system configuration): `push` publishes world←local
on stream `world_from_local` on every update (and once a second of sim time for late subscribers);
`request` answers it on service `world_from_local`. It follows the controller's `state` stream for
the motion in `local`.
"""

from __future__ import annotations

import asyncio
import logging

from eddie.errors import BadMessage, EddieError
from eddie.messages.controller import ControllerState, Position, PositionQuery
from eddie.messages.navigator import LineFixMessage, PointFixMessage, WorldFromLocal, WorldFromLocalQuery
from eddie.navigator.navigator import Navigator
from eddie.toolkit.message import Message
from eddie.toolkit.module import Incoming, Module
from wire.lockstep import lockstep_enabled
from wire.ratelimit import warn_limited

__all__ = ["NavigatorModule", "DELIVERY_MODES"]

log = logging.getLogger(__name__)

#: The ways world←local reaches a subscriber.
DELIVERY_MODES = ("push", "request")
#: refusals in a row at which the navigator first says its estimate and its fixes disagree (then at 2×, 4× …)
DOUBT_SAY_AFTER = 10


class NavigatorModule:
    """Run a `Navigator` on endpoint `m`, following module `controller`, delivering by `deliver` (push / request)."""

    def __init__(self, m: Module, nav: Navigator, *, deliver: frozenset[str] = frozenset(DELIVERY_MODES),
                 controller: str = "controller", republish_s: float = 1.0) -> None:
        bad = set(deliver) - set(DELIVERY_MODES)
        if bad:
            raise ValueError(f"deliver: unknown mode {sorted(bad)[0]!r} (push or request)")
        self.m = m
        self.nav = nav
        self.deliver = deliver
        self.controller = controller
        self.republish_s = republish_s
        self._started = asyncio.Event()

    def _on_state(self, st: ControllerState) -> None:
        first = not self.nav.started
        for t, x, y, yaw in st.trail:  # the periods a held-up controller missed
            self.nav.on_passed(t, x, y, yaw)
        self.nav.on_local(st.stamp, st.x, st.y, st.yaw)
        if first:
            self._started.set()
            self._push()

    def _push(self) -> None:
        w = self.nav.world_from_local()
        if w is not None and "push" in self.deliver:
            self.m.publish("world_from_local", w)

    async def _answer(self, inc: Incoming) -> Message:
        if not isinstance(inc.message, WorldFromLocalQuery):
            raise BadMessage(f"world_from_local from {inc.sender!r}: expected a WorldFromLocalQuery", sender=inc.sender,
                             field="type")
        w = self.nav.world_from_local()
        if w is None:
            raise BadMessage("world←local is not known yet (no controller state)", sender=inc.sender, field="stamp")
        return w

    async def run(self) -> None:
        """Follow the controller, take fixes, deliver world←local until cancelled."""
        m = self.m
        m.subscribe(self.controller, "state", ControllerState, self._on_state)
        if "request" in self.deliver:
            m.serve("world_from_local", self._answer)
        if lockstep_enabled():
            await self._first_position()
        await self._started.wait()
        m.ready()
        republish = asyncio.ensure_future(self._republish())
        try:
            while True:
                try:
                    inc = await m.receive()
                except BadMessage as exc:
                    warn_limited(log, "bad-inbox", "navigator: %.200s", exc)
                    continue
                if not isinstance(inc.message, (PointFixMessage, LineFixMessage)):
                    warn_limited(log, "not-a-fix", "navigator: %s from %.60s is not a fix; ignored", type(inc.message).__name__, inc.sender)
                    continue
                try:
                    w: WorldFromLocal = self.nav.fix(inc.message, m.now() or inc.message.stamp)
                except BadMessage as exc:
                    warn_limited(log, "bad-fix", "navigator: %.200s", exc)
                    self._say_if_doubting()
                    continue
                log.info("navigator: t=%.2f fix from %s (stamp %.2f): world←local (%.2f, %.2f, %.3f)",
                         m.clock.now_or(-1.0), inc.sender, inc.message.stamp, w.x, w.y, w.yaw)
                self._push()
        finally:
            republish.cancel()

    def _say_if_doubting(self) -> None:
        """Say so, at 10, 20, 40 … refusals in a row, when the estimate and its fixes have disagreed for long."""
        n = self.nav.refused_in_row
        q, r = divmod(n, DOUBT_SAY_AFTER)
        if q and not r and q & (q - 1) == 0:
            log.warning("navigator: %d fixes in a row refused (the covariance doubled %d times since the last used fix, "
                        "at places %.1f m apart): the estimate and its fixes disagree", n, self.nav.fix_gate.doubled,
                        self.nav.fix_gate.doubt_step_m)

    async def _first_position(self) -> None:
        """Lock-step: take the first local pose from the controller's position service.

        The simulator holds sim time until the mission is accepted, so the controller's state stream
        (one message per control period of sim time) may have gone out before this module subscribed.
        """
        while not self._started.is_set():
            try:
                pos = await self.m.request(self.controller, "position", PositionQuery(), reply_type=Position)
            except EddieError as exc:  # not up yet, or no odometry yet: ask again
                warn_limited(log, "first-position", "navigator: waiting for the controller's position: %.200s", exc)
                try:  # its state stream may say it first; else ask again (wall time: start-up only, sim time held)
                    await asyncio.wait_for(self._started.wait(), 0.1)
                except asyncio.TimeoutError:
                    pass
                continue
            if not self.nav.started:
                self._on_state(ControllerState(stamp=pos.stamp, x=pos.x, y=pos.y, yaw=pos.yaw, v=pos.v, curvature=0.0))

    async def _republish(self) -> None:
        while True:
            await self.m.clock.sleep(self.republish_s)
            self._push()
