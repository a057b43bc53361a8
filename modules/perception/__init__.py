"""PERCEPTION: colored-range sensor fusion that finds the passage and fixes the position (seed: Sidewalk 1986 §3).

Layers (one common data interface between them): PERCEPTION MONITOR (`monitor`), PATCH MAKER
(the `patch_maker` sub-package: colour, range and overlap segmentation, patches), OBJECT FINDER (`object_finder`),
POSITION CALIBRATOR (`calibrator`); `pipeline` runs one cycle, `frame_cycles` a run of frames over vision workers. The process on the blackboard is
`codger.perception`; EDDIE's modules run the same pipeline.
"""

from modules.perception.calibrator import CalibrationError, CalibrationResult, EdgeObservation, PointObservation, calibrate
from modules.perception.patch_maker import (
    ColourClass, ColourModel, ColourModelError, Patch, PatchSet, RangeSegParams, Segmentation, SegmentationParams, Segmented, SurfaceType,
    ColourPrior, make_patches, make_segmentation, overlap_labels, segment_range,
)
from modules.perception.errors import PerceptionError
from modules.perception.image import ColoredRangeImage, ImageError
from modules.perception.monitor import (
    InputPosition, ResolutionTable, SensorGeometry, ViewPlan, image_input_position, segmentation_params, select_segmentation,
)
from modules.perception.object_finder import FoundObject, find_objects
from modules.perception.pipeline import PerceptionPipeline, PipelineOutput
from modules.perception.frame_cycles import FrameJob, process_frames
from modules.perception.sensor_frame import SensorFrame, SensorFrameError, colored_range_image, decode_sensor_frame

__all__ = [
    "CalibrationError", "CalibrationResult", "EdgeObservation", "PointObservation", "calibrate",
    "ColourClass", "ColourModel", "ColourModelError", "ColourPrior", "ColoredRangeImage", "ImageError", "PerceptionError",
    "InputPosition", "ResolutionTable", "SensorGeometry", "ViewPlan", "image_input_position", "segmentation_params",
    "select_segmentation", "FoundObject", "find_objects", "overlap_labels",
    "Segmentation", "SegmentationParams", "Segmented", "make_segmentation", "Patch", "PatchSet", "make_patches",
    "PerceptionPipeline", "PipelineOutput", "RangeSegParams", "SurfaceType", "segment_range",
    "SensorFrame", "SensorFrameError", "colored_range_image", "decode_sensor_frame",
    "FrameJob", "process_frames",
]
