"""The CAPTAIN's pure core: sequence a mission's steps, apply triggers, keep the mission status."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from modules.vocabulary import Mission, MissionStatus, MissionStep, StepOutcome, StepResult
from modules.captain.errors import CaptainError

__all__ = ["Next", "MissionRun", "SequenceError"]


class SequenceError(CaptainError, RuntimeError):
    """A result or command that does not fit the mission's current state."""


@dataclass(frozen=True)
class Next:
    """What to do after a step ended: issue `step`, wait until sim time `until` [s] then resume, or stop."""

    kind: Literal["step", "wait", "done"]
    step: MissionStep | None = None
    until: float | None = None


class MissionRun:
    """One mission being sequenced: which step runs, the outcomes so far, the mission status.

    Pure: no I/O; the caller posts the steps and status it returns and feeds results and times [s].
    """

    def __init__(self, mission: Mission, *, submitted_at: float | None = None) -> None:
        self.mission = mission
        self._state = "queued"
        self._current: int | None = None
        self._reason = ""
        self._submitted_at = submitted_at
        self._finished_at: float | None = None
        self._outcomes = [StepOutcome(step_index=i, name=s.name) for i, s in enumerate(mission.steps)]

    # ---- views ------------------------------------------------------------------------------

    @property
    def status(self) -> MissionStatus:
        """Return the current mission status."""
        return MissionStatus(
            mission_id=self.mission.mission_id, name=self.mission.name, state=self._state,  # type: ignore[arg-type]
            current_step=self._current, step_count=len(self.mission.steps), steps=tuple(self._outcomes),
            reason=self._reason, submitted_at=self._submitted_at, finished_at=self._finished_at,
        )

    @property
    def finished(self) -> bool:
        """Return whether the mission has reached a terminal state."""
        return self.status.terminal

    @property
    def current_step(self) -> int | None:
        """Return the index of the step running or waiting, or None."""
        return self._current

    def step_token(self, index: int) -> MissionStep:
        """Return the mission step token for step `index` (destination and constraints only)."""
        spec = self.mission.steps[index]
        return MissionStep(mission_id=self.mission.mission_id, step_index=index, name=spec.name,
                           destination=spec.destination, constraints=spec.constraints)

    # ---- transitions ------------------------------------------------------------------------

    def start(self, now: float) -> MissionStep:
        """Start the mission at sim time `now` [s]; return the first step to issue."""
        if self._state != "queued":
            raise SequenceError(f"mission {self.mission.mission_id} is {self._state}, cannot start")
        self._state = "running"
        return self._issue(0, now)

    def _issue(self, index: int, now: float) -> MissionStep:
        self._current = index
        self._outcomes[index] = self._outcomes[index].model_copy(update={"state": "running", "started_at": now})
        return self.step_token(index)

    def _finish(self, state: str, now: float, reason: str) -> Next:
        self._state = state
        self._reason = reason
        self._finished_at = now
        for i, o in enumerate(self._outcomes):
            if o.state == "pending":
                self._outcomes[i] = o.model_copy(update={"state": "cancelled", "reason": "not reached"})
            elif o.state == "waiting":
                self._outcomes[i] = o.model_copy(update={"state": "succeeded"})
            elif o.state == "running":
                new = "failed" if state == "failed" else "cancelled"
                self._outcomes[i] = o.model_copy(update={"state": new, "reason": reason, "finished_at": now})
        self._current = None
        return Next(kind="done")

    def step_finished(self, result: StepResult, now: float) -> Next:
        """Apply a step result at sim time `now` [s]: trigger action on success, mission failure otherwise."""
        if self._state != "running" or self._current is None:
            raise SequenceError(f"mission {self.mission.mission_id} is {self._state}; no step is running")
        if result.mission_id != self.mission.mission_id or result.step_index != self._current:
            raise SequenceError(f"result for {result.mission_id} step {result.step_index} does not match running "
                                f"step {self._current} of {self.mission.mission_id}")
        i = self._current
        spec = self.mission.steps[i]
        if self._outcomes[i].state != "running":
            raise SequenceError(f"step {i} is {self._outcomes[i].state}, not running")
        if not result.success:
            self._outcomes[i] = self._outcomes[i].model_copy(update={"state": "failed", "reason": result.reason, "finished_at": now})
            return self._finish("failed", now, f"step {i + 1} ({spec.name}) failed: {result.reason or 'no reason given'}")
        self._outcomes[i] = self._outcomes[i].model_copy(update={"state": "succeeded", "reason": result.reason, "finished_at": now})
        action = spec.trigger.action
        last = i == len(self.mission.steps) - 1
        if action == "stop":
            return self._finish("succeeded", now, f"stopped by the trigger of step {i + 1} ({spec.name})" if not last else "")
        if action == "wait":
            self._outcomes[i] = self._outcomes[i].model_copy(update={"state": "waiting"})
            return Next(kind="wait", until=now + spec.trigger.wait_s)
        if last:
            return self._finish("succeeded", now, "")
        return Next(kind="step", step=self._issue(i + 1, now))

    def wait_over(self, now: float) -> Next:
        """End a trigger's wait at sim time `now` [s]; return the next step or done."""
        i = self._current
        if self._state != "running" or i is None or self._outcomes[i].state != "waiting":
            raise SequenceError(f"mission {self.mission.mission_id} is not waiting")
        self._outcomes[i] = self._outcomes[i].model_copy(update={"state": "succeeded"})
        if i == len(self.mission.steps) - 1:
            return self._finish("succeeded", now, "")
        return Next(kind="step", step=self._issue(i + 1, now))

    def cancel(self, now: float, reason: str = "cancelled") -> None:
        """Cancel the mission at sim time `now` [s] (no effect once finished)."""
        if not self.finished:
            self._finish("cancelled", now, reason)

    def fail(self, now: float, reason: str) -> None:
        """Fail the mission at sim time `now` [s] for `reason` (no effect once finished)."""
        if not self.finished:
            self._finish("failed", now, reason)
