"""How things look: the colour a map states, the colour statistics and reflectance a world gives, weather, markings, the sun.

A map says what colour type an object is (GRAY, GREEN, … with a nominal colour, Sidewalk 1986 §3);
a world file also says how the renderer draws it (`Appearance`), how the ground changes over a run
(`Weather`), where paint lies on the roads (`Marking`), and where the sun stands (`Sun`).
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, field_validator

__all__ = ["COLOUR_TYPES", "ColourType", "MapColour", "ColourStats", "Appearance", "Weather", "MARKING_COLOURS", "Marking", "Sun"]

_FROZEN = ConfigDict(frozen=True, extra="forbid")


#: Colour types a map names (Sidewalk 1986 §3.3.4: "the types of color are GRAY and GREEN").
COLOUR_TYPES: tuple[str, ...] = ("GRAY", "GREEN", "BROWN", "RED", "BLUE", "YELLOW", "WHITE", "BLACK")
#: One of `COLOUR_TYPES`.
ColourType = Literal["GRAY", "GREEN", "BROWN", "RED", "BLUE", "YELLOW", "WHITE", "BLACK"]


def _rgb_range(v: tuple[float, float, float], hi: float = 255.0) -> tuple[float, float, float]:
    if not all(0.0 <= c <= hi and math.isfinite(c) for c in v):
        raise ValueError(f"each channel must be within 0..{hi:g}, got {list(v)}")
    return v


class MapColour(BaseModel):
    """What a map says of an object's colour: its colour type and a nominal sRGB colour in daylight [0–255].

    The nominal colour is a catalogue value (\"light gray concrete\"), not a measurement: the surface
    itself varies from object to object and over a run, and PERCEPTION adapts to what it sees.
    """

    model_config = _FROZEN

    type: ColourType
    nominal: tuple[float, float, float]

    @field_validator("nominal")
    @classmethod
    def _nominal_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v)


class ColourStats(BaseModel):
    """Gaussian colour statistics in sRGB under full sun: mean and standard deviation per channel [0–255]."""

    model_config = _FROZEN

    mean: tuple[float, float, float]
    std: tuple[float, float, float]

    @field_validator("mean")
    @classmethod
    def _mean_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v)

    @field_validator("std")
    @classmethod
    def _std_range(cls, v: tuple[float, float, float]) -> tuple[float, float, float]:
        return _rgb_range(v, 128.0)


class Appearance(ColourStats):
    """How the renderer draws a world object (world files only, never a map): colour statistics under full
    sun [0–255] (this object's own, weathering included), laser reflectance [0–1], a tree's crown colour."""

    reflectance: float = Field(default=0.5, ge=0.0, le=1.0)
    crown: ColourStats | None = None


class Weather(BaseModel):
    """How ground covers change over a run (world files only): wet patches that dry and return, fallen leaves.

    Each cover's share of the ground (`wet_cover`, `leaf_cover`, 0–1) swings by ±`swing` (relative)
    around its mean with period `period_s` [s] sim time; wet ground keeps `wet_brightness` (0–1] of its
    dry brightness; leaves have the colour statistics `leaves` [0–255].
    """

    model_config = _FROZEN

    wet_cover: float = Field(default=0.0, ge=0.0, le=1.0)
    wet_brightness: float = Field(default=0.6, gt=0.0, le=1.0)
    leaf_cover: float = Field(default=0.0, ge=0.0, le=1.0)
    leaves: ColourStats = ColourStats(mean=(150.0, 100.0, 50.0), std=(22.0, 18.0, 14.0))
    swing: float = Field(default=0.6, ge=0.0, le=1.0)
    period_s: float = Field(default=300.0, gt=0.0)


#: Paint colours of road markings (Navlab 1990 §2.2.2: yellow centre lines, white edge stripes).
MARKING_COLOURS: tuple[str, ...] = ("yellow", "white")


class Marking(BaseModel):
    """A painted stripe on a road (world files only): a polyline [m] in `world`, paint colour, width [m], dashes.

    `dash` is (painted, gap) [m] along the line for a broken stripe, None for a solid one. The stripe is
    drawn where it lies on its road; a map never states markings (a derived map drops them).
    """

    model_config = _FROZEN

    colour: Literal["yellow", "white"]
    line: tuple[tuple[float, float], ...] = Field(min_length=2)
    width: float = Field(gt=0.02, le=1.0)
    dash: tuple[float, float] | None = None

    @field_validator("line")
    @classmethod
    def _line_finite(cls, v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
        if not all(math.isfinite(c) for p in v for c in p):
            raise ValueError("every position must be finite")
        if any(p == q for p, q in zip(v, v[1:])):
            raise ValueError("consecutive positions must differ")
        return v

    @field_validator("dash")
    @classmethod
    def _dash_positive(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        if v is not None and not (v[0] > 0.0 and v[1] > 0.0 and math.isfinite(v[0] + v[1])):
            raise ValueError(f"dash is (painted, gap) [m], both > 0, got {list(v)}")
        return v


class Sun(BaseModel):
    """The sun direction: compass azimuth [deg] (0 = north, 90 = east) and elevation above the horizon [deg]."""

    model_config = _FROZEN
    azimuth_deg: float = Field(ge=0.0, le=360.0)
    elevation_deg: float = Field(gt=0.0, le=90.0)

    def direction(self) -> np.ndarray:
        """Return the unit vector towards the sun in the world frame (x east, y north, z up), shape (3,)."""
        az = math.radians(self.azimuth_deg)
        el = math.radians(self.elevation_deg)
        return np.array([math.sin(az) * math.cos(el), math.cos(az) * math.cos(el), math.sin(el)])
