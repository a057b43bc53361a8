"""The simulator's sensor preview: small images of each capture it serves, for the monitor and recordings.

PERCEPTION fetches captures with a `sim/capture` query, which no subscriber sees; so on every
capture it serves the simulator also publishes a `SimPreview` on `sim/preview` (droppable: it can
never slow the simulator). It carries a downsampled camera image and a colourised colored-range
image as JPEG or PNG bytes, the capture's sim stamp and sizes — no pose and no truth labels.
Wire form: msgpack of the model (bytes as msgpack bin).
"""

from __future__ import annotations

from typing import Literal

import msgpack
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from wire.errors import PayloadError

__all__ = ["PreviewImage", "SimPreview", "PreviewError", "encode_preview", "decode_preview"]


class PreviewError(PayloadError, ValueError):
    """A preview payload that does not decode; says what is wrong."""


class PreviewImage(BaseModel):
    """One encoded image: format, size [px] after downsampling, size of the source image [px], the bytes."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    format: Literal["jpeg", "png"]
    width: int = Field(gt=0)
    height: int = Field(gt=0)
    source_width: int = Field(gt=0)
    source_height: int = Field(gt=0)
    data: bytes


class SimPreview(BaseModel):
    """Preview of one capture at sim time `stamp` [s]: camera and colored-range images (either may be absent)."""

    model_config = ConfigDict(frozen=True, extra="ignore")

    stamp: float
    vehicle: str = ""
    camera: PreviewImage | None = None
    colored_range: PreviewImage | None = None
    #: capture sequence number of the simulator (counts every capture served)
    seq: int = Field(default=0, ge=0)


def encode_preview(p: SimPreview) -> bytes:
    """Return the msgpack wire form of a preview."""
    return msgpack.packb(p.model_dump(), use_bin_type=True)


def decode_preview(payload: bytes) -> SimPreview:
    """Return the preview in a msgpack payload; raise PreviewError saying what is wrong."""
    try:
        raw = msgpack.unpackb(payload, raw=False)
    except Exception as exc:  # noqa: BLE001 - msgpack raises assorted errors on garbage
        raise PreviewError(f"preview payload is not msgpack: {type(exc).__name__}") from None
    try:
        return SimPreview.model_validate(raw)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise PreviewError(f"invalid preview: {'.'.join(map(str, e['loc']))}: {e['msg']}") from None
