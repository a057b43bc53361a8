"""PERCEPTION: colored-range sensor fusion that finds the passage and fixes the position (seed: Sidewalk 1986 §3).

Layers (one common data interface between them): PERCEPTION MONITOR (`monitor`), PATCH MAKER
(`colour`, `range_seg`, `overlap`, `patches`, `patch_maker`), OBJECT FINDER (`object_finder`),
POSITION CALIBRATOR (`calibrator`); `pipeline` runs one cycle, `module` is the process.
"""

from modules.perception.calibrator import CalibrationError, CalibrationResult, EdgeObservation, PointObservation, calibrate
from modules.perception.colour import ColourClass, ColourModel, colour_type_name
from modules.perception.image import ColoredRangeImage
from modules.perception.monitor import (
    InputPosition, ResolutionTable, SensorGeometry, ViewPlan, image_input_position, segmentation_params, select_segmentation,
)
from modules.perception.object_finder import FoundObject, find_objects
from modules.perception.overlap import overlap_labels
from modules.perception.patch_maker import Segmentation, SegmentationParams, Segmented, make_segmentation
from modules.perception.patches import Patch, PatchSet, make_patches
from modules.perception.pipeline import PerceptionPipeline, PipelineOutput
from modules.perception.range_seg import RangeSegParams, SurfaceType, segment_range
from modules.perception.sensor_frame import SensorFrame, SensorFrameError, colored_range_image, decode_sensor_frame

__all__ = [
    "CalibrationError", "CalibrationResult", "EdgeObservation", "PointObservation", "calibrate",
    "ColourClass", "ColourModel", "colour_type_name", "ColoredRangeImage",
    "InputPosition", "ResolutionTable", "SensorGeometry", "ViewPlan", "image_input_position", "segmentation_params",
    "select_segmentation", "FoundObject", "find_objects", "overlap_labels",
    "Segmentation", "SegmentationParams", "Segmented", "make_segmentation", "Patch", "PatchSet", "make_patches",
    "PerceptionPipeline", "PipelineOutput", "RangeSegParams", "SurfaceType", "segment_range",
    "SensorFrame", "SensorFrameError", "colored_range_image", "decode_sensor_frame",
]
