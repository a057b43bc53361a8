"""Read a recording back: its channels and counts, and its messages in log-time order as JSON values.

A file whose recorder was killed has no summary; it is then read linearly as far as it goes.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Iterator, NamedTuple

from mcap.exceptions import McapError
from mcap.reader import make_reader

from sidewalk.recording.errors import RecordingError

__all__ = ["RecordedMessage", "ChannelInfo", "Recording", "open_recording"]

_MAGIC = b"\x89MCAP0\r\n"


class RecordedMessage(NamedTuple):
    """One recorded message: topic, schema name, log and publish sim times [s], the decoded JSON value."""

    topic: str
    schema: str
    log_time: float
    publish_time: float
    value: dict


class ChannelInfo(NamedTuple):
    """A channel of a recording: topic, schema name, schema (parsed JSON), message count (None: no summary)."""

    topic: str
    schema: str
    schema_data: dict
    count: int | None


class Recording:
    """An MCAP recording opened for reading (see `open_recording`)."""

    def __init__(self, path: Path) -> None:
        self.path = path

    def _reader(self, f):  # noqa: ANN001 - a binary file
        return make_reader(f)

    def channels(self) -> dict[str, ChannelInfo]:
        """Return the channels by topic, with message counts when the file has its summary."""
        with open(self.path, "rb") as f:
            try:
                summary = self._reader(f).get_summary()
            except McapError as exc:
                raise RecordingError(f"{self.path}: unreadable MCAP summary: {exc}") from None
        if summary is None:
            out: dict[str, ChannelInfo] = {}
            counts: dict[str, int] = {}
            for m in self.messages():
                counts[m.topic] = counts.get(m.topic, 0) + 1
                if m.topic not in out:
                    out[m.topic] = ChannelInfo(m.topic, m.schema, {}, None)
            return {t: c._replace(count=counts[t]) for t, c in out.items()}
        stats = summary.statistics
        out = {}
        for cid, ch in summary.channels.items():
            sc = summary.schemas.get(ch.schema_id)
            n = stats.channel_message_counts.get(cid) if stats is not None else None
            out[ch.topic] = ChannelInfo(ch.topic, sc.name if sc else "", json.loads(sc.data) if sc and sc.data else {}, n)
        return out

    def messages(self, topics: list[str] | None = None) -> Iterator[RecordedMessage]:
        """Yield the messages (of `topics`, default all) in log-time order."""
        with open(self.path, "rb") as f:
            try:
                for schema, ch, msg in self._reader(f).iter_messages(topics=topics, log_time_order=True):
                    try:
                        value = json.loads(msg.data)
                    except ValueError:
                        continue
                    yield RecordedMessage(ch.topic, schema.name if schema else "", msg.log_time / 1e9, msg.publish_time / 1e9, value)
            except McapError as exc:
                raise RecordingError(f"{self.path}: {exc}") from None

    def time_range(self) -> tuple[float, float]:
        """Return the first and last log times [s] (0, 0 for an empty file)."""
        with open(self.path, "rb") as f:
            summary = self._reader(f).get_summary()
        if summary is not None and summary.statistics is not None and summary.statistics.message_count:
            return summary.statistics.message_start_time / 1e9, summary.statistics.message_end_time / 1e9
        times = [m.log_time for m in self.messages()]
        return (min(times), max(times)) if times else (0.0, 0.0)


def open_recording(path: str | Path) -> Recording:
    """Return the recording at `path`; raise RecordingError with a one-line reason if it is missing or not MCAP."""
    p = Path(path)
    if not p.exists():
        raise RecordingError(f"no recording at {p}")
    if not p.is_file():
        raise RecordingError(f"{p} is not a file")
    try:
        with open(p, "rb") as f:
            head = f.read(len(_MAGIC))
    except OSError as exc:
        raise RecordingError(f"cannot read {p}: {exc.strerror or exc}") from None
    if head != _MAGIC:
        raise RecordingError(f"{p} is not an MCAP file (it does not start with the MCAP magic bytes)")
    return Recording(p)
