"""EDDIE's annotated map (seed §2.5, ch. 3): annotations, the 0.5 m grid, the database, triggers, GeoJSON files.

Pure: no network. The map manager process (`eddie.map_manager`) serves this over the toolkit.
"""

from eddie.annotated_map.annotation import Annotation, Location, LocationKind, TriggerMode
from eddie.annotated_map.database import AnnotationDatabase
from eddie.annotated_map.errors import AnnotatedMapError, AnnotationFileError, DuplicateAnnotation, UnknownAnnotation
from eddie.annotated_map.geojson_file import (annotations_from_geojson, annotations_to_geojson, load_annotations,
                                              save_annotations)
from eddie.annotated_map.grid import DEFAULT_CELL_M, Cell, Grid
from eddie.annotated_map.triggers import SMALL_JUMP_M, JumpKind, TriggerEvent, TriggerWalker

__all__ = [
    "Annotation", "Location", "LocationKind", "TriggerMode", "AnnotationDatabase", "AnnotatedMapError",
    "AnnotationFileError", "DuplicateAnnotation", "UnknownAnnotation", "annotations_from_geojson",
    "annotations_to_geojson", "load_annotations", "save_annotations", "DEFAULT_CELL_M", "Cell", "Grid",
    "SMALL_JUMP_M", "JumpKind", "TriggerEvent", "TriggerWalker",
]
