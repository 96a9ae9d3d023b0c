"""Defaults of reading a scan that the options read (:class:`meshplan.options.InputParams`),
kept apart from the readers: ``meshplan --version`` and ``meshplan run --help`` print them, and
importing :mod:`meshplan.io.points` for one number loaded numpy and the readers (about a third
of the start-up time)."""

from __future__ import annotations

__all__ = ["VOXEL_M"]

#: Default voxel size of the subsampling grid, in metres (``point_voxel_m``). 3 cm: coarser than
#: the 2 mm to 1 cm spacing of laser scans (a 2 mm scan keeps one point in about 200) and finer
#: than the 5 cm spacing of phone scans (kept whole), so that every scan comes out at one density,
#: at most about 1,100 points per m2; and three times finer than the smallest size any stage looks
#: at (the 4-inch depth of the flat-wall box, door jambs at 5 cm, the 2-inch level buckets), so
#: no stage sees the grid. A 10 cm wall keeps its two faces apart (the 16 neighbours of a point
#: lie within about 7 cm).
VOXEL_M = 0.03
