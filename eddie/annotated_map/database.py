"""The annotation database: annotations by id, indexed on the 0.5 m grid, with type-within-polygon queries.

Maps larger than memory (the seed's open problem): cells are stored **sparsely** — a dict from each
occupied cell to the ids of the annotations touching it — so memory grows with the annotated area,
not with the map's extent; empty ground costs nothing. (A window around the vehicle is not kept: the
sparse index of a whole campus route is a few thousand cells.)

A query takes the grid's candidates (the cells of the polygon's bounding box that are occupied) and
then tests each candidate exactly (shapely `intersects`: an annotation is *within* polygon Y when
any part of it lies in Y).
"""

from __future__ import annotations

from typing import Iterable, Sequence

import shapely

from eddie.annotated_map.annotation import Annotation
from eddie.annotated_map.errors import DuplicateAnnotation, UnknownAnnotation
from eddie.annotated_map.grid import Cell, Grid

__all__ = ["AnnotationDatabase"]


class AnnotationDatabase:
    """Annotations by id with a sparse grid index (cell → ids); the `used` flags live here."""

    def __init__(self, annotations: Iterable[Annotation] = (), *, grid: Grid | None = None) -> None:
        self.grid = grid or Grid()
        self._by_id: dict[str, Annotation] = {}
        self._geom: dict[str, shapely.Geometry] = {}
        self._cells: dict[Cell, set[str]] = {}
        for a in annotations:
            self.add(a)

    def __len__(self) -> int:
        return len(self._by_id)

    def __iter__(self):
        return iter(self._by_id.values())

    def __contains__(self, aid: object) -> bool:
        return aid in self._by_id

    @property
    def occupied_cells(self) -> int:
        """Return how many grid cells hold at least one annotation."""
        return len(self._cells)

    def get(self, aid: str) -> Annotation:
        """Return annotation `aid` (raises UnknownAnnotation)."""
        try:
            return self._by_id[aid]
        except KeyError:
            raise UnknownAnnotation(f"no annotation {aid!r}") from None

    def geometry(self, aid: str) -> shapely.Geometry:
        """Return the shapely geometry [m] `world` of annotation `aid`."""
        return self._geom[aid]

    def _cells_of(self, a: Annotation, g: shapely.Geometry) -> Iterable[Cell]:
        loc = a.location
        pad = a.reach
        if loc.kind == "line" and pad == 0.0:
            for p, q in zip(loc.points, loc.points[1:]):
                yield from self.grid.supercover(p[0], p[1], q[0], q[1])
            return
        xmin, ymin, xmax, ymax = loc.bounds()
        cand = list(self.grid.box(xmin - pad, ymin - pad, xmax + pad, ymax + pad))
        if len(cand) <= 4:
            yield from cand
            return
        gg = g.buffer(pad) if pad > 0 else g
        shapely.prepare(gg)
        for c in cand:
            if gg.intersects(shapely.box(*self.grid.cell_box(c))):
                yield c

    def add(self, a: Annotation) -> None:
        """Add annotation `a` (raises DuplicateAnnotation if its id is taken)."""
        if a.id in self._by_id:
            raise DuplicateAnnotation(f"annotation id {a.id!r} twice")
        g = a.location.geometry()
        self._by_id[a.id] = a
        self._geom[a.id] = g
        for c in set(self._cells_of(a, g)):
            self._cells.setdefault(c, set()).add(a.id)

    def remove(self, aid: str) -> Annotation:
        """Remove annotation `aid` and return it (raises UnknownAnnotation)."""
        a = self.get(aid)
        del self._by_id[aid]
        for c in set(self._cells_of(a, self._geom.pop(aid))):
            ids = self._cells.get(c)
            if ids is not None:
                ids.discard(aid)
                if not ids:
                    del self._cells[c]
        return a

    def set_used(self, aid: str, used: bool = True) -> None:
        """Set the `used` flag of annotation `aid`."""
        self._by_id[aid] = self.get(aid).with_used(used)

    def candidates(self, cells: Iterable[Cell]) -> set[str]:
        """Return the ids of annotations touching any of `cells`."""
        out: set[str] = set()
        for c in cells:
            s = self._cells.get(c)
            if s:
                out |= s
        return out

    def query(self, type: str | None = None, polygon: Sequence[tuple[float, float]] | None = None) -> list[Annotation]:
        """Return every annotation of `type` (any if None) within `polygon` [(x, y)] [m] `world` (anywhere if None), by id."""
        if polygon is None:
            hits = [a for a in self._by_id.values() if type is None or a.type == type]
            return sorted(hits, key=lambda a: a.id)
        poly = shapely.Polygon(polygon)
        if not poly.is_valid:
            poly = poly.buffer(0)
        shapely.prepare(poly)
        xmin, ymin, xmax, ymax = poly.bounds
        i0, j0 = self.grid.cell_of(xmin, ymin)
        i1, j1 = self.grid.cell_of(xmax, ymax)
        if (i1 - i0 + 1) * (j1 - j0 + 1) > len(self._cells):
            cand = self.candidates(c for c in self._cells if i0 <= c[0] <= i1 and j0 <= c[1] <= j1)
        else:
            cand = self.candidates(self.grid.box(xmin, ymin, xmax, ymax))
        hits = []
        for aid in cand:
            a = self._by_id[aid]
            if type is not None and a.type != type:
                continue
            if poly.intersects(self._geom[aid]):
                hits.append(a)
        return sorted(hits, key=lambda a: a.id)
