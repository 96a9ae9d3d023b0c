"""Doors and windows: openings in the flat walls (not in the paper, which left them to future work).

Each wall's triangles are rasterized on a grid along the wall and up (``opening_cell_m``). The
bands next to the floor and the ceiling are ignored (scanners round the corners off there). Every
empty region of the grid that is enclosed by wall, roughly rectangular, and of a plausible size
is an opening:

* a *door* reaches down to the floor, is ``door_width_m`` wide and ``door_height_m`` high, and
  has wall above it (a full-height gap is a missing piece of scan, not a door);
* a *window* has wall below it (a sill at least ``window_sill_m`` above the floor) and above it.

Random holes in a scan are not rectangular and are left alone. The opening's edges are then
refined from the triangle corners along them, well below the grid cell.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..geometry import FloatArray, IntArray, Mesh
from ..orient import Orientation
from ..walls import FlatWalls
from .params import PlanParams
from .rooms import sample_triangles


@dataclass(frozen=True, eq=False)
class Openings:
    """Doors and windows, one row each (parallel arrays); ``u_min``/``u_max`` are along the
    wall's tangent, ``bottom``/``top`` heights in the plan frame."""

    story: IntArray
    kind: tuple[str, ...]
    wall: IntArray
    u_min: FloatArray
    u_max: FloatArray
    bottom: FloatArray
    top: FloatArray

    def __len__(self) -> int:
        return int(len(self.wall))

    @property
    def width(self) -> FloatArray:
        return self.u_max - self.u_min

    def center(self, walls: FlatWalls) -> FloatArray:
        """``(N, 2)`` plan position [x, z] of each opening's middle on its wall."""
        u = 0.5 * (self.u_min + self.u_max)
        return u[:, None] * walls.tangent[self.wall] + walls.offset[self.wall][:, None] * walls.normal[self.wall]

    def holes(self) -> dict[int, list[tuple[float, float, float, float]]]:
        """Wall index -> rectangles ``(u_min, u_max, bottom, top)`` to cut out of the flat walls."""
        out: dict[int, list] = {}
        for i in range(len(self)):
            out.setdefault(int(self.wall[i]), []).append((self.u_min[i], self.u_max[i], self.bottom[i], self.top[i]))
        return out

    def to_list(self, walls: FlatWalls, ndigits: int = 4) -> list[dict]:
        c = self.center(walls)
        return [
            {
                "story": int(self.story[i]),
                "kind": self.kind[i],
                "wall": int(self.wall[i]),
                "center": (np.round(c[i], ndigits) + 0.0).tolist(),
                "width": round(float(self.width[i]), ndigits),
                "bottom": round(float(self.bottom[i]), ndigits),
                "top": round(float(self.top[i]), ndigits),
            }
            for i in range(len(self))
        ]


def _empty() -> Openings:
    z = np.zeros(0)
    return Openings(np.zeros(0, np.int64), (), np.zeros(0, np.int64), z, z, z, z)


def find_openings(mesh: Mesh, orientation: Orientation, walls: FlatWalls, params: PlanParams | None = None) -> Openings:
    """Doors and windows in every flat wall."""
    params = params or PlanParams()
    face_wall = walls.face_walls()
    order = np.argsort(face_wall, kind="stable")
    sorted_walls = face_wall[order]
    rows: list[tuple] = []
    for w in range(len(walls)):
        a, b = np.searchsorted(sorted_walls, [w, w + 1])
        faces = order[a:b]
        if not len(faces):
            continue
        story = orientation.stories[int(walls.story[w])]
        rows.extend(_wall_openings(mesh.triangles[faces], walls, w, story.floor, story.ceiling, params))
    if not rows:
        return _empty()
    rows.sort(key=lambda r: (int(walls.story[r[1]]), r[1], r[2]))
    return Openings(
        story=np.array([walls.story[r[1]] for r in rows], dtype=np.int64),
        kind=tuple(r[0] for r in rows),
        wall=np.array([r[1] for r in rows], dtype=np.int64),
        u_min=np.array([r[2] for r in rows]),
        u_max=np.array([r[3] for r in rows]),
        bottom=np.array([r[4] for r in rows]),
        top=np.array([r[5] for r in rows]),
    )


def _wall_openings(tri: FloatArray, walls: FlatWalls, w: int, floor: float, ceiling: float, params: PlanParams) -> list[tuple]:
    cell = params.opening_cell_m
    t3 = np.array([walls.tangent[w][0], 0.0, walls.tangent[w][1]])
    u0, u1 = walls.u_min[w], walls.u_max[w]
    pts = sample_triangles(tri, 0.7 * cell)
    pu, py = pts @ t3, pts[:, 1]
    ncol = max(1, int(np.ceil((u1 - u0) / cell)))
    nrow = max(1, int(np.ceil((ceiling - floor) / cell)))
    c = np.clip(np.floor((pu - u0) / cell).astype(np.int64), 0, ncol - 1)
    r = np.clip(np.floor((py - floor) / cell).astype(np.int64), 0, nrow - 1)
    grid = np.zeros((nrow, ncol), dtype=bool)
    grid[r, c] = True
    grid = ndimage.binary_closing(grid, structure=np.ones((2, 2)), border_value=1)
    margin = int(np.ceil(params.opening_margin_m / cell))
    grid[:margin] = True
    grid[nrow - margin :] = True
    labels, n = ndimage.label(~grid)
    if n == 0:
        return []
    verts = tri.reshape(-1, 3)
    vu, vy = verts @ t3, verts[:, 1]
    out = []
    for k, sl in enumerate(ndimage.find_objects(labels), start=1):
        rs, cs = sl
        if cs.start == 0 or cs.stop == ncol:
            continue  # open to the end of the wall
        box = labels[sl] == k
        if box.mean() < params.opening_rectangularity:
            continue
        left, right = u0 + cs.start * cell, u0 + cs.stop * cell
        low, high = floor + rs.start * cell, floor + rs.stop * cell
        width, touches_floor = right - left, rs.start <= margin
        if rs.stop >= nrow - margin:
            continue  # no wall above: a missing strip, not an opening
        kind = None
        door_wide = params.door_width_m[0] - 2 * cell <= width <= params.door_width_m[1] + 2 * cell
        window_wide = params.window_width_m[0] - 2 * cell <= width <= params.window_width_m[1] + 2 * cell
        if touches_floor and door_wide and high - floor >= params.door_height_m - 2 * cell:
            kind = "door"
        elif not touches_floor and low - floor >= params.window_sill_m - cell and window_wide and high - low >= params.window_height_m:
            kind = "window"
        if kind is None:
            continue
        # refine the edges from the triangle corners next to them
        band = (vy > low + 2 * cell) & (vy < high - 2 * cell)
        mid = 0.5 * (left + right)
        lv = vu[band & (vu <= mid) & (vu >= left - 2 * cell)]
        rv = vu[band & (vu >= mid) & (vu <= right + 2 * cell)]
        left = float(lv.max()) if len(lv) else left
        right = float(rv.min()) if len(rv) else right
        across = (vu > left + 2 * cell) & (vu < right - 2 * cell)
        tv = vy[across & (vy >= 0.5 * (low + high)) & (vy <= high + 2 * cell)]
        top = float(tv.min()) if len(tv) else high
        if kind == "door":
            bottom = floor
        else:
            bv = vy[across & (vy <= 0.5 * (low + high)) & (vy >= low - 2 * cell)]
            bottom = float(bv.max()) if len(bv) else low
        limits = params.door_width_m if kind == "door" else params.window_width_m
        if not (limits[0] <= right - left <= limits[1]):
            continue
        out.append((kind, w, left, right, bottom, top))
    return out
