"""The annotated map's errors: one root (`AnnotatedMapError`, an `EddieError`), typed sub-errors."""

from __future__ import annotations

from eddie.errors import EddieError

__all__ = ["AnnotatedMapError", "AnnotationFileError", "DuplicateAnnotation", "UnknownAnnotation"]


class AnnotatedMapError(EddieError):
    """Root of every error raised by `eddie.annotated_map`."""


class AnnotationFileError(AnnotatedMapError, ValueError):
    """A bad annotated map file; the message names the file, the feature (index and id) and the field."""

    def __init__(self, path: str, text: str, *, feature: int | None = None, feature_id: str | None = None,
                 field: str = "") -> None:
        self.path = path
        self.feature = feature
        self.feature_id = feature_id
        self.field = field
        where = path
        if feature is not None:
            where += f": feature {feature}" + (f" (id {feature_id!r})" if feature_id else "")
        if field:
            where += f": field {field!r}"
        super().__init__(f"{where}: {text}")


class DuplicateAnnotation(AnnotatedMapError, ValueError):
    """An annotation id already in the database."""


class UnknownAnnotation(AnnotatedMapError, KeyError):
    """An annotation id not in the database."""
