"""Double-height spaces (issue 16): where a story's floor is open to the story below.

A room two stories high (a hall, a living room under the roof) leaves a hole in the upper
story's floor that is no stair's: the upper plan must mark it, as it marks the hole over a stair
(:func:`meshplan.plan.stairs.stair_void`), so that nobody reads it as floor that was not
scanned. It is found from what a scan shows of it, on a grid of :data:`CELL_M`:

* the lower story's floor was scanned there (a room lies under it);
* the slab between the stories was not: no horizontal face at the lower story's ceiling or at
  the upper story's floor (either winding: the winding repair may turn a slab's piece over);
* the walls around it rise past the upper floor: along :data:`WALLED_SHARE` of its outline,
  something was scanned higher than :data:`ABOVE_FLOOR_M` over the upper floor, within
  :data:`OUTLINE_BAND_M`. A part of the
  upper story that nobody scanned has no slab in the scan either, but nothing was seen above it
  from below, through the slab;
* it is larger than :data:`MIN_AREA_M2` (smaller gaps in a slab are holes in the scan), and it
  is not a stair's opening (those are the stairs' own voids).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import shapely
from shapely.geometry import Polygon

from ..geometry import Mesh
from ..orient.stories import slab_faces
from .closure import straighten
from .rooms import FloorRaster, _raster, floor_raster, footprint_raster, sample_triangles

if TYPE_CHECKING:  # pragma: no cover
    from ..orient import Orientation
    from .stairs import StairElement

__all__ = ["Void", "double_height_voids"]

#: Grid (m) of the rasters the voids are read from: the rooms' floor grid.
CELL_M = 0.1
#: The lower floor is closed over gaps up to this (m; furniture standing on it) ...
FLOOR_CLOSING_M = 0.5
#: ... and the slab grown by this (m) before the void is cut out of it: a slab scanned in
#: patches is still a slab between them.
SLAB_GROWTH_M = 0.3
#: A void is at least this large (m2): a hall's or a living room's height, not a gap in the
#: scan of a slab (those are a few tenths of a square metre) nor a duct's shaft.
MIN_AREA_M2 = 2.0
#: Narrower than this (m) across, a strip of no slab is a gap between a slab and a wall.
MIN_WIDTH_M = 0.6
#: Something scanned this high (m) over the upper floor ...
ABOVE_FLOOR_M = 0.5
#: ... within this distance (m) of the void's outline (the slab's growth, the cells the openings
#: and closings move it by, and a wall's thickness) ...
OUTLINE_BAND_M = 0.7
#: ... along at least this share of it: the walls of the double-height space rise past the
#: upper floor on three of its four sides at least (a gallery's railing may stand on the fourth).
WALLED_SHARE = 0.75
#: The void reaches the walls' faces: faces within 17 degrees of vertical (``|n_y|`` under
#: this) ...
WALL_NORMAL_Y = 0.3
#: ... higher than this over the lower floor (m: above the furniture standing against them).
WALL_ABOVE_M = 1.2
#: A stair's footprint and its void, grown by this (m), are the stair's opening, not a void.
STAIR_CLEARANCE_M = 0.3
#: The void is drawn as the rectangle it fills where that lies within this (m) of its raster
#: outline (three cells: a void's outline is the edge of the upper floor, which no furniture
#: hides, unlike a room's floor: :attr:`meshplan.plan.params.PlanParams.open_room_fit_m`), else smoothed over this
#: (m; a cell and a half).
FIT_M, SMOOTH_M = 0.3, 0.15


@dataclass(frozen=True, eq=False)
class Void:
    """A hole in the floor of ``story`` (plan frame) over a space two stories high."""

    story: int
    polygon: Polygon
    kind: str = "double-height"
    source: str = "scan"


def _cells(m: float) -> int:
    return max(1, int(round(m / CELL_M)))


def double_height_voids(
    mesh: Mesh, orientation: Orientation, stairs: tuple[StairElement, ...] = (), tolerance_m: float = 0.1
) -> tuple[Void, ...]:
    """The double-height voids in the floors of every story above the first (plan frame mesh).

    Parameters
    ----------
    mesh
        The mesh in the plan frame.
    orientation
        Its stories (floors, ceilings) and each face's story.
    stairs
        The stairs found: their openings are theirs, not voids.
    tolerance_m
        How far from a slab's height its faces lie (the stories' slab tolerance).
    """
    from scipy import ndimage

    stories = orientation.stories
    if len(stories) < 2:
        return ()
    heights, ny = mesh.face_centroids[:, 1], mesh.face_normals[:, 1]
    out: list[Void] = []
    for k in range(1, len(stories)):
        lower, upper = stories[k - 1], stories[k]
        floor = floor_raster(mesh, orientation, lower, tolerance_m, CELL_M)
        if not floor.grid.any():
            continue

        # the slab: the lower story's ceiling or the upper story's floor, either face of it
        slab_sel = slab_faces(heights, ny, (upper,), tolerance_m, ceilings=False)
        if lower.ceiling_found:
            slab_sel |= slab_faces(heights, ny, (lower,), tolerance_m, floors=False)
        slab = _covered(mesh, slab_sel, floor)
        # what was seen over the upper floor: the corners of its faces mark their cells
        high = (heights > upper.floor + ABOVE_FLOOR_M) & (heights < upper.top)
        seen_above = _raster(mesh.vertices[mesh.faces[high]].reshape(-1, 3)[:, [0, 2]], CELL_M, like=floor).grid
        under = ndimage.binary_fill_holes(ndimage.binary_closing(floor.grid, iterations=_cells(FLOOR_CLOSING_M)))
        # where the lower story stands: its floor and what stands on it, the walls' feet included
        stands = footprint_raster(mesh, orientation, lower, floor, FLOOR_CLOSING_M).grid | under
        # ... up to the walls' faces: what stands above the furniture, vertical
        upright = (np.abs(ny) < WALL_NORMAL_Y) & (heights > lower.floor + WALL_ABOVE_M) & (heights < lower.top)
        stands &= ~_covered(mesh, upright, floor)
        open_ = under & ~ndimage.binary_dilation(slab, iterations=_cells(SLAB_GROWTH_M))
        open_ = ndimage.binary_opening(open_, iterations=max(1, _cells(MIN_WIDTH_M) // 2))
        mine = [p.buffer(STAIR_CLEARANCE_M) for st in stairs if upper.index in (st.story, st.to_story) for p in (st.footprint, st.void) if p is not None]
        openings = shapely.union_all(mine) if mine else None
        if openings is not None:
            open_ &= ~_inside(openings, floor, open_.shape)
        labels, n = ndimage.label(open_)
        walls_near = ndimage.binary_dilation(seen_above, iterations=_cells(OUTLINE_BAND_M))
        for j in range(1, n + 1):
            comp = labels == j
            if comp.sum() * CELL_M**2 < MIN_AREA_M2:
                continue
            edge = comp & ~ndimage.binary_erosion(comp)
            if walls_near[edge].mean() < WALLED_SHARE:
                continue
            # out to the slab's edge and to the walls (the floor under the furniture along them)
            comp = ndimage.binary_dilation(comp, iterations=_cells(OUTLINE_BAND_M), mask=stands & ~slab)
            shape = FloorRaster(floor.x0, floor.z0, CELL_M, comp).outline(0.0)
            if shape is None:
                continue
            parts = [p for p in shapely.get_parts(shape) if isinstance(p, Polygon)]
            if not parts:
                continue
            poly = Polygon(max(parts, key=lambda p: p.area).exterior)
            # a raster's stepped edge as the rectangle it fills, where one does (as a room closed
            # by its scanned floor is drawn), less the stairs' openings
            poly = straighten(poly, openings, FIT_M, SMOOTH_M)
            out.append(Void(upper.index, shapely.orient_polygons(poly)))
    return tuple(out)


def _covered(mesh: Mesh, faces: np.ndarray, grid: FloorRaster) -> np.ndarray:
    """The cells of ``grid`` that the faces in the mask ``faces`` cover."""
    return _raster(sample_triangles(mesh.triangles[faces], CELL_M)[:, [0, 2]], CELL_M, like=grid).grid


def _inside(poly, raster: FloorRaster, shape: tuple[int, int]) -> np.ndarray:
    """Which cells of a grid on ``raster``'s origin have their centres in ``poly``."""
    r, c = np.indices(shape)
    return shapely.contains_xy(poly, raster.x0 + (c + 0.5) * raster.cell, raster.z0 + (r + 0.5) * raster.cell)
