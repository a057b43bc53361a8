"""Recordings: every run written to `run.mcap` (JSON-schema channels, Foxglove poses and scenes), and read back."""

from sidewalk.recording.errors import RecordingError
from sidewalk.recording.reader import ChannelInfo, RecordedMessage, Recording, open_recording
from sidewalk.recording.recorder import ANNOTATIONS_TOPIC, RunRecorder, token_dict

__all__ = [
    "RecordingError", "ChannelInfo", "RecordedMessage", "Recording", "open_recording", "RunRecorder", "token_dict",
    "ANNOTATIONS_TOPIC",
]
