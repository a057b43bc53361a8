"""The command supervisor: which drive command executes at sim time t, and the watchdog that stops the vehicle.

Rules (all times sim time [s]):

* an `immediate` command replaces the executing one and clears the queue;
* a `queued` command (always timed) runs after the queued ones; an open-ended command executing when
  it arrives is superseded at once (open-ended means "until the next command");
* a command's steps (`DriveCommand.then`) are queued right behind it, in order;
* a timed command holds for its `duration`, then the next queued one starts exactly at its end;
* the watchdog: an open-ended command not refreshed within `timeout` is dropped and the vehicle is told
  to stop (`Supervision.tripped`); when timed commands run out the vehicle is told to stop as well
  (`Supervision.exhausted`).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from wire.drive import DriveCommand

__all__ = ["CommandSupervisor", "Supervision", "STOP"]

#: What the vehicle executes when nothing else is: stop, steering straight.
STOP = DriveCommand(speed=0.0, curvature=0.0)


@dataclass(frozen=True, slots=True)
class Supervision:
    """The command to execute now; `tripped` / `exhausted` are True on the one tick the vehicle was stopped."""

    command: DriveCommand
    tripped: bool = False
    exhausted: bool = False
    idle: bool = False


class CommandSupervisor:
    """Hold the executing command and the queue; decide at each tick what the vehicle executes."""

    def __init__(self, timeout: float = 0.5) -> None:
        if not timeout > 0.0:
            raise ValueError(f"watchdog timeout must be > 0 s, got {timeout}")
        self.timeout = float(timeout)
        self._current: DriveCommand | None = None
        self._end: float | None = None  # end time of the current timed command
        self._queue: deque[DriveCommand] = deque()
        self._last_rx = -float("inf")

    @property
    def queued(self) -> int:
        """Return the number of commands waiting behind the executing one."""
        return len(self._queue)

    @property
    def last_received(self) -> float:
        """Return the sim time [s] of the last submitted command."""
        return self._last_rx

    def submit(self, command: DriveCommand, t: float) -> None:
        """Accept `command` at sim time `t` [s] (and its steps behind it)."""
        self._last_rx = t
        steps = [DriveCommand(speed=s.speed, curvature=s.curvature, turn_rate=s.turn_rate, duration=s.duration, mode="queued",
                              seq=command.seq, sensed_at=command.sensed_at) for s in command.then]
        if command.mode == "immediate":
            self._queue.clear()
            self._current = command
            self._end = t + command.duration if command.duration is not None else None
            self._queue.extend(steps)
            return
        if self._current is not None and self._end is None:
            # the open-ended command lasted "until the next one"
            self._current = None
        if self._current is None:
            self._current = command
            self._end = t + command.duration  # type: ignore[operator]
        else:
            self._queue.append(command)
        self._queue.extend(steps)

    def clear(self) -> None:
        """Drop the executing command and the queue."""
        self._current = None
        self._end = None
        self._queue.clear()

    def tick(self, t: float) -> Supervision:
        """Return what to execute at sim time `t` [s], advancing through timed commands that ended."""
        exhausted = False
        while self._current is not None and self._end is not None and t >= self._end - 1e-12:
            if self._queue:
                nxt = self._queue.popleft()
                start = self._end
                self._current = nxt
                self._end = start + nxt.duration  # type: ignore[operator]
            else:
                self._current = None
                self._end = None
                exhausted = True
        if self._current is None:
            return Supervision(command=STOP, exhausted=exhausted, idle=True)
        if self._end is None and t - self._last_rx > self.timeout:
            self.clear()
            return Supervision(command=STOP, tripped=True, idle=True)
        return Supervision(command=self._current)
