"""Door and window candidates in one wall face (used by :mod:`meshplan.plan.openings`).

Two kinds of evidence, both read in the face's own frame (``u`` along the wall, ``y`` up, ``d``
across it, positive into the room the face was scanned from):

* **gaps**: every triangle of the story that faces along the wall's normal (either way, within
  ``opening_facing_deg``) and lies in the wall's *slab* (from ``opening_slab_m`` in front of
  the face to ``opening_wall_depth_m`` behind it) is rasterized on a grid along the wall and
  up. The slab holds the face, the other face of the same wall and pieces of the same wall set
  back or forward a little, so a door between two collinear pieces is a gap in one raster, and
  a door seen from one side only is a gap too. A door leaf standing open, a jamb, a reveal face
  along the wall's normal, not across it, so they do not fill the gap. The raster runs on past
  the face's ends by up to the widest door, so a gap between this face and the next piece of
  wall is seen; where a perpendicular wall crosses the line (a corner) the raster stops and the
  corner is a jamb. An empty region is a door when it reaches the floor, has a door's width,
  straight jambs and a head at door height (a lintel above it), or, where the scan missed the
  lintel, runs up to the ceiling with the floor seen through it beyond the wall. It is a window
  when it has a sill and a head and straight edges on all four sides, or, where a scan hole
  runs into its frame, when the largest rectangle in the empty region is framed by wall on
  three sides at least, or, where the scan stopped below its head, when it is a notch from a
  sill up to where the jambs beside it were scanned. Scan holes are ragged and are left alone.
  A door's jambs are its *reveals*, the faces across the wall's depth: an open leaf's edge or
  the wedge of a leaf ajar in the slab beside its hinge is no jamb, and a doorway seen in the
  face's own plane over a closed leaf whose head was not scanned is a door only between
  reveals (a strip of the face the scan missed has none).
* **recesses**: a window whose glazing (a blind, a lattice) was scanned, set back in a reveal
  behind the face, leaves no gap in the slab. The face's own plane and the surfaces behind it
  that face the room are rasterized apart; a region behind the face where its plane is missing
  is a window when it has a window's size above a sill, the face's plane all round it (its
  frame), and a step at its edge: the depth drops from the frame to the glazing across the
  edge by a reveal's depth and by several times the face's own warp (a hollow of a warped mesh
  slopes into the region instead).
* **panels**: parametric models (RoomPlan, Quest scene models) model a door or a window as a
  separate box or quad in the wall plane, over an uncut wall. A separate connected piece of the
  mesh that lies in the wall's slab, covers its rectangle, is a modelled primitive (a few large
  triangles), stands on the floor, has a door's width and height and ends below the ceiling is
  such a door. A thin piece of a few large triangles (a modelled primitive, not a fragment of a
  real scan) centred on the wall's plane, clear of the floor and below the ceiling, with a
  window's width and height, is a window.

Why one long module: a face's raster (built once) serves both searches, doors read column by
column and windows as regions, with the shared edge and straightness tests; the parametric door
boxes use the same slab.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy import ndimage

from .._kernels import max_corner_distance, sample_faces, scatter_max, scatter_min
from ..geometry import FloatArray, IntArray, Mesh, max3, min3
from ..walls import FlatWalls
from ..walls.flat import AJAR_MIN_TURN_DEG
from .params import PlanParams

#: Edges longer than this (m) are halved before sampling: :func:`~meshplan.plan.rooms.sample_triangles` puts at most 64
#: samples along an edge, too few on a parametric wall's 5-10 m triangles for a 5 cm grid.
MAX_SAMPLED_EDGE_M = 1.5

#: Faces whose normal is within this of vertical (cosine) and that lie within
#: :data:`FLOOR_BAND_M` of the story's floor are floor (seen through a doorway).
FLOOR_NORMAL_COS = 0.9
#: Height band (m) around the story's floor in which floor faces are looked for (floor noise
#: and the few centimetres of a threshold).
FLOOR_BAND_M = 0.1
#: How far beyond a wall's face (m) the floor seen through a gap is looked for: the wall's
#: thickness and about a metre of the room behind, which any scan of that room shows.
FLOOR_BEYOND_M = 1.2

#: Faces reaching further than this (m) from their centroid (parametric models' large
#: triangles) are tested one by one; smaller ones are found by their sorted centroids.
BIG_FACE_M = 0.5

#: A parametric door panel covers at least this share of its bounding rectangle on the grid (a
#: box or quad does, a stray fragment of a real scan does not).
PANEL_COVERAGE = 0.9
#: Pieces of more faces than this are not parametric door panels (a box is 12 triangles, a
#: quad 2; a real scan's fragments of this size are furniture or clutter).
PANEL_MAX_FACES = 200

#: A window panel is a modelled primitive: its largest triangle covers at least this share of
#: its rectangle (a quad's two triangles cover half each, a box's front faces the same), which
#: no fragment of a real scan of tens of triangles does.
PANEL_PRIMITIVE_SHARE = 0.25
#: A window panel lies in the wall's plane: its middle within this distance (m) of the face and
#: its thickness at most :data:`PANEL_THICKNESS_M` (RoomPlan's and Quest's window boxes are flat,
#: mm to cm; a television or a picture box stands in front of the wall).
PANEL_PLANE_M = 0.02
PANEL_THICKNESS_M = 0.05
#: A window panel's bottom is at least this far (m) above the floor (a door panel stands on it;
#: modelled full-height glazing has sills of 0.1-0.2 m).
PANEL_SILL_MIN_M = 0.1

#: A window's glazing (or its blind, its lattice) stands back from the inner face of its wall in
#: a reveal: a surface facing the room at least this far (m) behind the face's plane, where the
#: plane itself was not scanned, is looked at as a window too (less is plaster and scan noise).
#: On the two real scans with such windows this works from 3 to 3.5 cm only (at 2.5 cm the
#: tatami room's recess joins a recessed strip past the wall's end; at 4 cm the scattered
#: samples of both glazings fall short): the region is found this way, the step test below
#: decides, and no value in that range adds a false window on the real or synthetic scans.
RECESS_MIN_M = 0.03
#: ... and such a recess is a window when the surface set back in it covers at least this share
#: of its rectangle (glazing, blinds and lattices scan patchily: reflections, slats) ...
RECESS_FILL = 0.5
#: ... and the face's plane was scanned along at least this share of each of its four sides (its
#: frame: sill, head and jambs in the wall's plane; a desk's knee space has no sill, a step in
#: the wall no jambs).
RECESS_FRAME_SHARE = 0.75

#: A door's leaf, closed, stands back from the inner face of its wall: it shuts against the stop
#: of its frame, behind the casing and the reveal (4-15 cm; hl1_hemkinator's 15 cm), while the
#: warp of a scanned wall over a door's width stays under 2 cm. A gap in the face's own plane
#: (this far behind it at most), from the floor to a lintel in that plane, between jambs, is
#: looked at as a door even where the slab behind it holds a surface (the leaf, or the room
#: beyond seen through the doorway).
LEAF_SET_BACK_M = 0.04
#: A column's front (:func:`_local_front`): this percentile of its samples' depths, the surface
#: nearest the room less the scan's noise (1-2 cm) in its last tenth.
FRONT_PERCENTILE = 90.0
#: ... read from a histogram of depths in bins this deep (m): a fifth of the set-back that makes
#: a leaf (:data:`LEAF_SET_BACK_M`).
FRONT_BIN_M = 0.008
#: Dips in the fronts of a face's columns up to this wide (m) are filled from both sides to give
#: the wall's front (:func:`_local_front`): the widest door leaf (1.5 m, ``door_width_m``) and
#: its frame.
LEAF_FRONT_SPAN_M = 1.7
#: ... and a leaf stands back from the front most of the wall around it shows, over this span
#: (m, centred on it): two door widths either side, where furniture against the wall (shelves,
#: cabinets) covers less than half.
WALL_FRONT_SPAN_M = 4.0

#: A recess within this distance (m) of a door or window found in the same face is part of it
#: (the leaf or the room beyond seen through a doorway, the reveal around a window's hole), not
#: a window of its own.
RECESS_APART_M = 0.3

#: A reveal is a step, where a hollow of the scan is a slope: read two cells (of
#: ``opening_cell_m``) from a recess's edge on either side (past the edge cell, which holds
#: both surfaces), the frame outside it and the glazing inside it are this many cells apart ...
RECESS_STEP_CELLS = 2
#: ... and the glazing stands at least this far (m) behind the frame there. A window's frame or
#: sash sets its glass back 4 cm or more from the inner face (the shallowest reveal measured,
#: glass and blinds of a HoloLens office, steps 5.5 cm); a panel set 2-3 cm into the wall (a
#: sliding door in its track) and the smooth warp of a mesh (HoloLens and the synthetic scans
#: bend by 0.5-2 cm over 0.3-3 m, sloping into a hollow over all its width) step less over
#: those 15 cm, except in the strongest warps, which the next test catches.
RECESS_STEP_M = 0.04
#: ... and at least this many times the face's own warp (the robust standard deviation of the
#: depth of its surface outside the recesses): a hollow of a smooth random warp drops a few of
#: its standard deviations below its surroundings (at most 2.6 in synthetic scans whose warp is
#: at the strongest, 2 cm), while a reveal's step is set by the window, not the warp (4 to 5.5
#: times on the scanned walls with glazed reveals); three standard deviations, the usual bound
#: of noise.
RECESS_STEP_SPREAD = 3.0
#: The standard deviation of a normal distribution is this times its median absolute deviation.
MAD_TO_SIGMA = 1.4826

#: A face in the line of a door's wall (:func:`_in_line`) turns from it by at most this angle
#: (degrees): the scatter of one wall's pieces on a drifting scan.
COLLINEAR_DOOR_DEG = 10.0
#: A leaf's surface, as the scan clusters it, runs past its door's width by at most this much
#: (m): the rounded corner at its hinge and the frame beside it.
AJAR_HINGE_M = 0.2
#: A door leaf's thickness (m; 4 cm is the common hollow-core leaf): its far side lies that far
#: behind the plane fitted to the side clustered as its surface, and an open leaf standing in
#: its doorway narrows it by as much (:mod:`meshplan.plan.elements`' clear width).
LEAF_THICKNESS_M = 0.04
#: Faces within this distance (m) of an ajar leaf's plane, over its length, are the leaf's: its
#: two faces 4 cm apart, their noise, and the plane fitted to the face scanned better.
AJAR_LEAF_DEPTH_M = 0.07
#: ... and its plane lies within ``collinear_m`` plus this much (m) of the face's own, either
#: way: behind it the other side of the same wall (a partition's thickness); in front of it a
#: piece of the same wall that a drifting scan set off its plane (the HoloLens office's wall
#: beside its door stands 11 cm proud of the piece across the door).
MAX_DOOR_WALL_M = 0.3

#: Tallest common door head above the floor (m; heads are 1.9-2.4 m): beside a gap whose lintel
#: the scan missed, a wall rises above it, while wardrobes and partition screens (2.0-2.2 m) do not;
#: a gap whose "lintel" was scanned higher is no door (it runs up into the rounded-off corner
#: between wall and ceiling, a bulkhead or a scan hole; a passage that high has no leaf).
DOOR_HEAD_MAX_M = 2.4

#: A gap whose jambs end where the wall beside them ends (the scan stopped there: a user who did
#: not look up scans walls to 1.4-2.0 m) has its head in unscanned space. It is a door when that
#: wall rises at least this high above the floor (m): above every work surface (bar counters
#: 1.1-1.2 m, ``WallParams.max_work_surface_m``), so that a gap between two counter or desk
#: fronts with the floor beyond is none.
HEAD_UNSEEN_MIN_TOP_M = 1.2

#: How far along the wall beside each jamb (m) the wall's own scanned top is read, for
#: :data:`HEAD_UNSEEN_MIN_TOP_M`: about a door's width, within the one room the jamb is seen from.
HEAD_UNSEEN_CONTEXT_M = 1.0

#: Head given to a door whose head was not scanned (m above its floor): a standard leaf (1.98-2.03 m,
#: 6 ft 8 in) in its frame.
DOOR_HEAD_ASSUMED_M = 2.05

#: Cells (of ``opening_cell_m``) an edge may stray from its median and still be straight, and
#: the tolerance of the size tests: the grid's own quantization and the closing.
EDGE_CELLS = 2
#: The same for a window's four edges, one cell: a window is small, and a round scan hole of
#: half a metre keeps its edge within two cells of the median over most of its height.
WINDOW_EDGE_CELLS = 1


@dataclass(frozen=True)
class Candidate:
    """One opening found in one wall face (``u`` along its tangent, heights in the plan frame)."""

    kind: str
    wall: int
    u_min: float
    u_max: float
    bottom: float
    top: float
    #: "gap", "no lintel" (the scan missed the lintel), "head unseen" (the scan stopped below the
    #: head, with the wall's top), "corner", "panel", "recess" (glazing set back) or "leaf" (a
    #: closed leaf set back)
    how: str
    #: a hole in the scan ran into its frame: the opening is the largest rectangle in its ragged
    #: empty region (:func:`_with_ragged_windows`), its width an estimate
    ragged: bool = False


class WallEvidence:
    """The mesh arranged once for every wall face's search.

    Several threads may search walls at once (:func:`meshplan.plan.openings.find_openings`):
    what is computed on demand is published whole once computed (a thread that finds it
    missing computes the same again), never filled in place.
    """

    def __init__(self, mesh: Mesh, walls: FlatWalls, params: PlanParams, thickness: FloatArray | None = None) -> None:
        self.mesh = mesh
        self.walls = walls
        self.params = params
        #: per face, the thickness (m) of its physical wall (measured between its two faces, or
        #: the default of a wall seen from one side); ``nan`` where unknown
        self.thickness = np.asarray(thickness, dtype=np.float64) if thickness is not None else np.full(len(walls), np.nan)
        self.tri = mesh.triangles
        self.normals = mesh.face_normals
        self.centroids = mesh.face_centroids
        cos = np.cos(np.radians(params.opening_facing_deg))
        # vertical enough to be wall (either winding: HoloLens meshes mix them)
        self.vertical = np.flatnonzero(np.abs(self.normals[:, 1]) <= np.sin(np.radians(params.opening_facing_deg)) + 1e-12)
        self.cos = cos
        self.floorish = np.flatnonzero(np.abs(self.normals[:, 1]) >= FLOOR_NORMAL_COS)
        # each face's reach from its centroid, so that a cheap test on centroids finds the
        # faces that may cross a wall's slab before their corners are projected
        tri = np.ascontiguousarray(self.tri)
        centres = np.broadcast_to(np.ascontiguousarray(self.centroids)[:, None, :], tri.shape)
        self.radius = max_corner_distance(tri, centres, 0) if len(tri) else np.zeros(0)
        # the mean plan normal of the DBSCAN segment (kept as a wall or not) each face of the
        # mesh was clustered in, zero for faces in none: a segment's faces share its surface
        seg = walls.face_segment if len(walls.face_segment) == len(tri) else np.full(len(tri), -1, dtype=np.int64)
        self.segment_normal = np.zeros((len(tri), 2))
        if np.any(seg >= 0):
            ok = seg >= 0
            k = int(seg.max()) + 1
            w = mesh.face_areas[ok]
            sums: FloatArray = np.stack([np.bincount(seg[ok], weights=w * self.normals[ok, j], minlength=k) for j in (0, 2)], axis=1)
            sn = sums / np.maximum(np.linalg.norm(sums, axis=1), 1e-12)[:, None]
            self.segment_normal[ok] = sn[seg[ok]]
        self.segment = seg
        self._cache: dict[tuple, tuple[tuple[FloatArray, FloatArray], IntArray, IntArray]] = {}
        self._ajar: dict[int, tuple[FloatArray, FloatArray, float] | None] = {}
        self._segment_offset: FloatArray | None = None
        self._panels: tuple[IntArray, IntArray] | None = None
        self._vertical_normals: FloatArray | None = None

    def segment_distance(self, faces: IntArray) -> FloatArray:
        """Distance (m) of each of ``faces``' centroids from the plane of the DBSCAN segment it
        was clustered in (``inf`` for faces in none). The planes' offsets along their normals
        (area-weighted means of their faces') are computed once, for the first face that asks
        (an ajar leaf's, :func:`_gaps`)."""
        if self._segment_offset is None:
            seg, ok = self.segment, self.segment >= 0
            w = self.mesh.face_areas[ok]
            d = np.einsum("ij,ij->i", self.centroids[ok][:, [0, 2]], self.segment_normal[ok])
            k = int(seg.max()) + 1 if ok.any() else 0
            per = np.bincount(seg[ok], weights=w * d, minlength=k) / np.maximum(np.bincount(seg[ok], weights=w, minlength=k), 1e-12)
            offsets = np.zeros(len(seg))
            offsets[ok] = per[seg[ok]]
            self._segment_offset = offsets  # complete when published: walls are searched in threads
        n = self.segment_normal[faces]
        d = np.abs(np.einsum("ij,ij->i", self.centroids[faces][:, [0, 2]], n) - self._segment_offset[faces])
        return np.where(self.segment[faces] >= 0, d, np.inf)

    def ajar_leaf(self, segment: int, floor: float) -> tuple[FloatArray, FloatArray, float] | None:
        """The DBSCAN ``segment`` as a door leaf: ``(centre, normal, half_length)`` of its plane in
        plan (x, z), or ``None`` when it is not shaped like one. A leaf is as long along its plane
        as a door is wide (``door_width_m``, plus up to :data:`AJAR_HINGE_M`; shorter pieces of
        a wall, 0.2-0.55 m clustered on their own beside a window's jamb, have normals skewed by
        the jamb's rounded edge), stands on the floor (its foot within ``opening_margin_m``) and
        rises above every work surface as the wall beside it does
        (:data:`HEAD_UNSEEN_MIN_TOP_M`; the wall under a window's sill does not), but not above
        a door's head (:data:`DOOR_HEAD_MAX_M`; a drifting wall's piece runs up to the
        ceiling)."""
        if segment not in self._ajar:
            faces = np.flatnonzero(self.segment == segment)
            pts = self.tri[faces].reshape(-1, 3)
            n = self.segment_normal[faces[0]]
            t = np.array([-n[1], n[0]])
            along = pts[:, [0, 2]] @ t
            lo, hi = float(along.min()), float(along.max())
            params = self.params
            top = float(pts[:, 1].max())
            leafy = (
                params.door_width_m[0] <= hi - lo <= params.door_width_m[1] + AJAR_HINGE_M
                and floor + HEAD_UNSEEN_MIN_TOP_M <= top <= floor + DOOR_HEAD_MAX_M
                and float(pts[:, 1].min()) <= floor + params.opening_margin_m
            )
            w = self.mesh.face_areas[faces]
            depth = float(np.average(self.centroids[faces][:, [0, 2]] @ n, weights=w)) if w.sum() > 0 else float(np.mean(pts[:, [0, 2]] @ n))
            self._ajar[segment] = (depth * n + 0.5 * (lo + hi) * t, n, 0.5 * (hi - lo)) if leafy else None
        return self._ajar[segment]

    def _sorted(self, key: tuple, w: int, faces: IntArray) -> tuple[tuple[FloatArray, FloatArray], IntArray, IntArray]:
        """``faces`` with a small reach and their centroids' positions along face ``w``'s
        direction normal and along its tangent (two ``(n,)`` arrays), and those with a large reach
        (parametric triangles), cached by ``key``. (Not sorted: a pass over the positions per
        face searched costs less than the sort, and every use of the faces found is independent
        of their order.)"""
        if key not in self._cache:
            n3 = self._direction_normal(w)
            t3 = np.array([-n3[2], 0.0, n3[0]])
            big = self.radius[faces] > BIG_FACE_M
            small = faces[~big]
            c = self.centroids[small]
            self._cache[key] = ((c @ n3, c @ t3), small, faces[big])
        return self._cache[key]

    def _direction_normal(self, w: int) -> FloatArray:
        d = self.walls.directions[int(self.walls.direction[w])]
        return np.array([d[0], 0.0, d[1]])

    def slab_faces(self, faces: IntArray, key: tuple, w: int, d_range: tuple[float, float], u_range: tuple[float, float]) -> IntArray:
        """The ``faces`` (cached by ``key``) that may reach into the box ``d_range`` across and
        ``u_range`` along face ``w``.

        The faces are placed along the normal of the face's *direction* (shared by every face
        of it), while the box is in the face's own frame: a face drawn at its own angle (a
        drifted wall, 1-10 degrees off its direction) runs across its direction's normal by
        ``u * sin(angle)``, so the box's extent along it is taken from its four corners."""
        pos, small, big = self._sorted(key, w, faces)
        n_dir = self._direction_normal(w)[[0, 2]]
        t_dir = np.array([-n_dir[1], n_dir[0]])
        n, t = self.walls.normal[w], self.walls.tangent[w]
        off = float(self.walls.offset[w])
        box = [n * (off + d) + t * u for d in d_range for u in u_range]
        across = [float(n_dir @ c) for c in box]
        along = [float(t_dir @ c) for c in box]
        # along the direction too: a reveal's box is a few decimetres of a wall several metres
        # long, whose faces the search then reads (0.34 s of the 3M-face apartment's openings).
        # The search (:meth:`near`) widens the box by a face's reach along the face's own axes:
        # seen along the direction's axes, turned from them, that is up to sqrt(2) times as far
        reach = np.sqrt(2.0) * BIG_FACE_M
        keep = (pos[0] >= min(across) - reach) & (pos[0] < max(across) + reach)
        keep &= (pos[1] >= min(along) - reach) & (pos[1] < max(along) + reach)
        return np.concatenate([small[keep], big])

    def facing(self, w: int, d_range: tuple[float, float], u_range: tuple[float, float]) -> IntArray:
        """The vertical faces facing along face ``w``'s normal that may reach the box ``d_range``
        across and ``u_range`` along it."""
        key = ("facing", int(self.walls.direction[w]))
        if key not in self._cache:
            n3 = self._direction_normal(w)
            v = self.vertical
            if self._vertical_normals is None:
                self._vertical_normals = self.normals[v]
            self._sorted(key, w, v[np.abs(self._vertical_normals @ n3) >= self.cos])
        return self.slab_faces(np.zeros(0, np.int64), key, w, d_range, u_range)

    def across(self, w: int, d_range: tuple[float, float], u_range: tuple[float, float]) -> IntArray:
        """The vertical faces facing along face ``w``'s tangent (either way, within
        ``opening_facing_deg``), jambs, reveals and returns across its wall's depth, that may
        reach the box ``d_range`` across and ``u_range`` along it."""
        key = ("across", int(self.walls.direction[w]))
        if key not in self._cache:
            n3 = self._direction_normal(w)
            t3 = np.array([-n3[2], 0.0, n3[0]])
            v = self.vertical
            if self._vertical_normals is None:
                self._vertical_normals = self.normals[v]
            self._sorted(key, w, v[np.abs(self._vertical_normals @ t3) >= self.cos])
        return self.slab_faces(np.zeros(0, np.int64), key, w, d_range, u_range)

    def floor_faces(self, w: int, floor: float, d_range: tuple[float, float], u_range: tuple[float, float]) -> IntArray:
        """The floor faces at height ``floor`` that may reach the box ``d_range`` across and
        ``u_range`` along face ``w``."""
        key = ("floor", int(self.walls.direction[w]), round(floor, 6))
        if key not in self._cache:
            f = self.floorish
            self._sorted(key, w, f[np.abs(self.centroids[f, 1] - floor) <= FLOOR_BAND_M])
        return self.slab_faces(np.zeros(0, np.int64), key, w, d_range, u_range)

    def near(
        self, faces: IntArray, n3: FloatArray, t3: FloatArray, off: float,
        d_range: tuple[float, float], u_range: tuple[float, float], y_range: tuple[float, float],
    ) -> IntArray:
        """The ``faces`` whose reach from their centroid overlaps the box ``d_range`` across,
        ``u_range`` along and ``y_range`` up a wall (a superset of those crossing it)."""
        c, r = self.centroids[faces], self.radius[faces]
        d, u = c @ n3 - off, c @ t3
        ok = (d + r >= d_range[0]) & (d - r <= d_range[1]) & (u + r >= u_range[0]) & (u - r <= u_range[1])
        ok &= (c[:, 1] + r >= y_range[0]) & (c[:, 1] - r <= y_range[1])
        return faces[ok]

    def panels(self) -> tuple[IntArray, IntArray]:
        """``(faces, starts)``: the faces of every small separate piece of the mesh that is tall
        enough for a door or a window, grouped (piece ``i`` is ``faces[starts[i]:starts[i + 1]]``)."""
        if self._panels is None:
            f = self.mesh.faces
            empty = (np.zeros(0, np.int64), np.zeros(1, np.int64))
            if not len(f):
                self._panels = empty
                return empty
            # the connected pieces, each labelled by its lowest vertex (labels in the order of
            # scipy's connected_components over the vertices, which is all that is used): the
            # mesh's own, which the plan mesh has from the orientation (0.15 s at 3M faces)
            flab = self.mesh.face_roots
            k = int(flab.max()) + 1
            counts = np.bincount(flab, minlength=k)
            y = self.tri[:, :, 1]
            ymin = np.full(k, np.inf)
            ymax = np.full(k, -np.inf)
            scatter_min(ymin, flab, min3(y))
            scatter_max(ymax, flab, max3(y))
            shortest = min(self.params.door_height_m, self.params.window_height_m)
            tall = (counts <= PANEL_MAX_FACES) & (ymax - ymin >= shortest - EDGE_CELLS * self.params.opening_cell_m)
            sel = np.flatnonzero(tall[flab])
            if not len(sel):
                self._panels = empty
                return empty
            order = sel[np.argsort(flab[sel], kind="stable")]
            lab = flab[order]
            starts = np.r_[0, np.flatnonzero(np.diff(lab)) + 1, len(order)]
            self._panels = (order, starts.astype(np.int64))
        return self._panels


def _subdivide(tri: FloatArray, longest: float) -> FloatArray:
    """Split triangles into four at their edge midpoints until no edge exceeds ``longest``.

    The reference of the compiled :func:`meshplan._kernels.sample_faces` (which :func:`_samples`
    uses): the same pieces, corner order and all."""
    out = []
    while len(tri):
        edge = np.max(np.linalg.norm(tri - np.roll(tri, 1, axis=1), axis=2), axis=1)
        big = edge > longest
        out.append(tri[~big])
        t = tri[big]
        if not len(t):
            break
        a, b, c = t[:, 0], t[:, 1], t[:, 2]
        ab, bc, ca = 0.5 * (a + b), 0.5 * (b + c), 0.5 * (c + a)
        tri = np.concatenate([np.stack(s, axis=1) for s in ((a, ab, ca), (ab, b, bc), (ca, bc, c), (ab, bc, ca))])
    return np.concatenate(out) if out else np.zeros((0, 3, 3))


def _samples(tri: FloatArray, cell: float) -> FloatArray:
    """Points covering the faces ``tri`` on a grid finer than ``cell``: the points of
    ``sample_triangles(_subdivide(tri, MAX_SAMPLED_EDGE_M), 0.7 * cell)`` (to rounding), in one
    compiled pass (no copies of the pieces)."""
    if not len(tri):
        return np.zeros((0, 3))
    return sample_faces(np.ascontiguousarray(tri, dtype=np.float64), MAX_SAMPLED_EDGE_M, 0.7 * cell)


def _straight(box: np.ndarray, tolerance: int, share: float) -> bool:
    """Whether the first and last filled cell of each row of ``box`` stay within ``tolerance``
    cells of their medians in at least ``share`` of the rows (a straight pair of edges)."""
    rows = np.flatnonzero(box.any(axis=1))
    if not len(rows):
        return False
    b = box[rows]
    first = np.argmax(b, axis=1)
    last = b.shape[1] - 1 - np.argmax(b[:, ::-1], axis=1)
    ok = (np.abs(first - np.median(first)) <= tolerance) & (np.abs(last - np.median(last)) <= tolerance)
    return bool(ok.mean() >= share)


def _corner_limits(walls: FlatWalls, w: int, lo: float, hi: float, corner: float) -> tuple[float | None, float | None]:
    """Where perpendicular walls of the same story cross face ``w``'s line just beyond its ends
    (within ``corner`` of the searched range ``[lo, hi]``'s face ends): the corners that end it."""
    tangent = walls.tangent  # built once here, not once per wall
    n, t, off = walls.normal[w], tangent[w], walls.offset[w]
    left = right = None
    for p in range(len(walls)):
        if p == w or walls.story[p] != walls.story[w]:
            continue
        c = float(walls.normal[p] @ t)
        if abs(c) < np.cos(np.radians(10.0)):
            continue
        u = (walls.offset[p] - off * float(walls.normal[p] @ n)) / c
        point = off * n + u * t
        up = float(tangent[p] @ point)
        if not (walls.u_min[p] - corner <= up <= walls.u_max[p] + corner):
            continue  # the perpendicular wall does not reach this wall's line
        if lo - corner <= u <= walls.u_min[w] + corner and (left is None or u > left):
            left = u
        if walls.u_max[w] - corner <= u <= hi + corner and (right is None or u < right):
            right = u
    return left, right


def wall_candidates(ev: WallEvidence, w: int, floor: float, ceiling: float) -> list[Candidate]:
    """Doors and windows in flat wall face ``w`` of a story from ``floor`` to ``ceiling``."""
    return _gaps(ev, w, floor, ceiling) + _panels(ev, w, floor, ceiling)


def _gaps(ev: WallEvidence, w: int, floor: float, ceiling: float) -> list[Candidate]:
    params, walls = ev.params, ev.walls
    cell = params.opening_cell_m
    n3 = np.array([walls.normal[w][0], 0.0, walls.normal[w][1]])
    t3 = np.array([walls.tangent[w][0], 0.0, walls.tangent[w][1]])
    off = float(walls.offset[w])
    near, far = params.opening_slab_m, -(params.opening_wall_depth_m + params.opening_slab_m)
    reach = params.door_width_m[1] + EDGE_CELLS * cell  # a door between this face and the next piece
    lo, hi = walls.u_min[w] - reach, walls.u_max[w] + reach
    left_corner, right_corner = _corner_limits(walls, w, lo, hi, params.door_corner_m)
    if left_corner is not None:
        lo = left_corner - EDGE_CELLS * cell
    if right_corner is not None:
        hi = right_corner + EDGE_CELLS * cell

    # triangles of the slab that face along the wall's normal
    cand = ev.near(ev.facing(w, (far, near), (lo, hi)), n3, t3, off, (far, near), (lo, hi), (floor, ceiling))
    # a face clustered with a surface that turns from this wall (a door leaf standing open a
    # little, whose faces near the hinge reach into the slab; a return) is no evidence of it
    seg_n = ev.segment_normal[cand]
    clustered = np.any(seg_n != 0.0, axis=1)
    cos_turn = np.abs(seg_n @ walls.normal[w])
    collinear = cos_turn >= np.cos(np.radians(COLLINEAR_DOOR_DEG))
    # ... nor is a leaf standing ajar (a few degrees open, within the scatter of a drifting
    # wall's pieces): a surface of its own, no longer than a door is wide and no taller
    # (its far face may be clustered with the wall's other face, which it nearly continues:
    # every face within a leaf's thickness of the leaf's plane, over its length, is the leaf)
    ajar = clustered & collinear & (cos_turn < np.cos(np.radians(AJAR_MIN_TURN_DEG)))
    leaves = [(int(s), lp) for s in np.unique(ev.segment[cand[ajar]]) if (lp := ev.ajar_leaf(int(s), floor)) is not None]
    if leaves:
        xz, own_plane = ev.centroids[cand][:, [0, 2]], ev.segment_distance(cand)
    for s, (centre, normal, half) in leaves:
        rel = xz - centre
        across, along = rel @ normal, rel @ np.array([-normal[1], normal[0]])
        # a face of another surface lies nearer that surface's plane than the leaf's far side
        # (the wall beside the hinge, which the leaf's plane passes within a few cm of)
        nearer = np.abs(across) < own_plane + LEAF_THICKNESS_M
        ajar_leaf = ((np.abs(across) <= AJAR_LEAF_DEPTH_M) & (np.abs(along) <= half) & nearer) | (ev.segment[cand] == s)
        collinear &= ~ajar_leaf
        clustered |= ajar_leaf
    cand = cand[~clustered | collinear]
    tv = ev.tri[cand]
    # each corner's depth across the face and position along it, in one pass over the corners
    # (the same numbers as two products with n3 and t3)
    nt = np.stack([n3, t3], axis=1)
    du = tv @ nt
    d = du[..., 0] - off
    u = du[..., 1]
    y = tv[:, :, 1]
    keep = (
        (max3(d) >= far) & (min3(d) <= near)
        & (max3(u) >= lo) & (min3(u) <= hi)
        & (max3(y) >= floor) & (min3(y) <= ceiling)
    )
    tri = tv[keep]
    if not len(tri):
        return []
    ncol = max(1, int(np.ceil((hi - lo) / cell)))
    nrow = max(1, int(np.ceil((ceiling - floor) / cell)))
    margin = int(np.ceil(params.opening_margin_m / cell))

    def cells(points: FloatArray) -> tuple[FloatArray, IntArray]:
        """Depth across the face and flat cell index of the ``points`` over the face's
        rectangle (projected once, rasterized by depth band with :func:`raster`)."""
        pdu = points @ nt
        pd, pu, py = pdu[:, 0] - off, pdu[:, 1], points[:, 1]
        ok = (pu >= lo) & (pu < hi) & (py >= floor) & (py < ceiling)
        c = np.clip(np.floor((pu[ok] - lo) / cell).astype(np.int64), 0, ncol - 1)
        r = np.clip(np.floor((py[ok] - floor) / cell).astype(np.int64), 0, nrow - 1)
        return pd[ok], r * ncol + c

    def raster(at: tuple[FloatArray, IntArray], front: float, back: float) -> np.ndarray:
        """Cells holding a point between ``back`` and ``front`` across the face."""
        pd, flat = at
        g = np.zeros(nrow * ncol, dtype=bool)
        g[flat[(pd >= back) & (pd <= front)]] = True
        return g.reshape(nrow, ncol)

    def closed(g: np.ndarray) -> np.ndarray:
        g = ndimage.binary_closing(g, structure=np.ones((2, 2)), border_value=1)
        g[:margin] = True
        g[nrow - margin :] = True
        # a corner is a jamb: the perpendicular wall closes the raster there
        if left_corner is not None:
            g[:, :EDGE_CELLS] = True
        if right_corner is not None:
            g[:, ncol - EDGE_CELLS :] = True
        return g

    pts = _samples(tri, cell)
    at = cells(pts)
    grid = closed(raster(at, near, far))

    # the corners in the slab: their depths and positions taken from those of the faces kept
    d_kept = d[keep]
    vd = d_kept.reshape(-1)
    in_slab = (vd >= far) & (vd <= near)
    vd, vu, vy = vd[in_slab], u[keep].reshape(-1)[in_slab], tri[:, :, 1].reshape(-1)[in_slab]
    floor_cols = _floor_beyond(ev, w, n3, t3, off, floor, lo, ncol, cell, params)
    # the wall's depth between its faces, inset from both (a leaf standing open at its hinge
    # reaches into the wall's depth by its thickness times the cosine of its angle at most)
    thick = float(ev.thickness[w])
    inner = (-(thick - REVEAL_INSET_M), -REVEAL_INSET_M) if thick > 2 * REVEAL_INSET_M else None

    face_raw = raster(at, near, -LEAF_SET_BACK_M)
    band = (floor + params.opening_margin_m, floor + HEAD_UNSEEN_MIN_TOP_M)
    band_rows = slice(margin, max(margin + 1, int(np.floor(HEAD_UNSEEN_MIN_TOP_M / cell))))
    lazy: dict[str, np.ndarray] = {}  # what leaf_between reads, made for the few faces that ask

    def leaf_between(a: float, b: float) -> bool:
        """Whether what the slab holds between ``a`` and ``b`` along the face (in the band of
        :data:`HEAD_UNSEEN_MIN_TOP_M`) stands off the face's plane (within :data:`LEAF_PLANE_M`
        of it in at most a quarter of the cells, ``opening_edge_straightness``) or is a leaf
        standing open: a plane turned from the face by :data:`LEAF_MIN_TURN_DEG` or more (depth
        growing along the face), the samples' median distance from it within :data:`LEAF_PLANE_M`."""
        if not lazy:
            lazy["face_plane"] = raster(at, LEAF_PLANE_M, -LEAF_PLANE_M)
            lazy["u"], lazy["d"] = pts @ t3, pts @ n3 - off
            lazy["in_band"] = (pts[:, 1] >= band[0]) & (pts[:, 1] <= band[1]) & (lazy["d"] >= far) & (lazy["d"] <= near)
        pts_u, pts_d = lazy["u"], lazy["d"]
        c0 = int(np.clip(np.floor((min(a, b) - lo) / cell) + 1, 0, ncol))
        c1 = int(np.clip(np.floor((max(a, b) - lo) / cell), 0, ncol))
        if c1 <= c0 or float(lazy["face_plane"][band_rows, c0:c1].mean()) <= 1.0 - params.opening_edge_straightness:
            return True  # the face's own plane (almost) empty: what the slab holds stands off it
        sel = lazy["in_band"] & (pts_u > min(a, b)) & (pts_u < max(a, b))
        if np.count_nonzero(sel) < 3:
            return False
        u, d = pts_u[sel], pts_d[sel]
        slope, icept = np.polyfit(u - u.mean(), d, 1)
        resid = d - (icept + slope * (u - u.mean()))
        return bool(abs(slope) >= np.tan(np.radians(LEAF_MIN_TURN_DEG)) and np.median(np.abs(resid)) <= LEAF_PLANE_M)

    def to_reveals(left: float, right: float) -> tuple[float, float]:
        """The jambs ``left`` and ``right`` moved out to the reveals beyond them (:data:`REVEAL_SHARE`):
        within :data:`REVEAL_REACH_M`, or up to :data:`LEAF_WEDGE_M` where the slab in between
        holds a leaf standing open at its hinge (``leaf_between``)."""
        if inner is None:
            return left, right
        out = []
        for u, toward in ((left, 1.0), (right, -1.0)):
            share, at = _reveal(ev, w, u, inner, band[0], band[1], toward)
            if share >= REVEAL_SHARE and 0.0 < (u - at) * toward <= REVEAL_REACH_M:
                u = at
            else:
                half = 0.5 * LEAF_WEDGE_M
                share, at = _reveal(ev, w, u - toward * half, inner, band[0], band[1], toward, reach=half)
                if share >= REVEAL_SHARE and REVEAL_REACH_M < (u - at) * toward <= LEAF_WEDGE_M and leaf_between(at, u):
                    u = at
            out.append(u)
        return out[0], out[1]

    frame = _Frame(grid, lo, floor, ceiling, cell, margin, vu, vy, w, left_corner is not None, right_corner is not None, to_reveals)
    found = _doors(frame, walls, floor_cols, params) + _windows(frame, walls, params)
    found += [c for c in _headless_windows(frame, walls, params) if not any(_overlap(c, o) for o in found)]
    found += [c for c in _notch_windows(frame, walls, params) if not any(_overlap(c, o) for o in found)]
    # doors whose leaf stands closed in its frame: the same reading on the face's own plane only,
    # where the whole slab shows something behind the face (the leaf or the room beyond); only
    # gaps under a lintel scanned in that plane (the frame on three sides) count
    # (only where some column of the face's plane is empty from the floor to a door's height
    # and the whole slab's is not: closing only fills cells, so the raw raster tells)
    # and along the face itself (past its ends the whole slab holds the other face of a wall
    # running on, or a corner's, and a leaf is looked for in the face it closes)
    door_rows = slice(margin, max(margin + 1, int(np.ceil(params.door_height_m / cell)) - EDGE_CELLS))
    col_u = lo + (np.arange(ncol) + 0.5) * cell
    on_face = (col_u >= walls.u_min[w]) & (col_u <= walls.u_max[w])
    # the face's plane is its fitted one, and where the wall on both sides of a closed leaf stands
    # in front of it, the wall's (:func:`_local_front`): a leaf set back by less than a DBSCAN
    # box's depth is clustered with the wall beside it into one face, whose plane it pulls onto
    # itself when it is the wider piece, so that the wall there stands in front of the plane and
    # the leaf in it (hard preset, seed 3: a leaf 7 cm back, 0.8 m wide, with 0.5 m of wall)
    planes: list[tuple[np.ndarray, np.ndarray]] = [(face_raw, vd >= -LEAF_SET_BACK_M)]
    narrowest = int(np.floor((params.door_width_m[0] - 2 * EDGE_CELLS * cell) / cell))
    local = _local_front(at, ncol, cell, door_rows, on_face, far, near, narrowest)
    if local is not None:
        pd_at, flat_at = at
        g_local = np.zeros(nrow * ncol, dtype=bool)
        g_local[flat_at[(pd_at >= local[flat_at % ncol] - LEAF_SET_BACK_M) & (pd_at <= near)]] = True
        v_col = np.clip(np.floor((vu - lo) / cell).astype(np.int64), 0, ncol - 1)
        planes.append((g_local.reshape(nrow, ncol), vd >= local[v_col] - LEAF_SET_BACK_M))
    for plane_raw, in_face in planes:
        if not (on_face & ~plane_raw[door_rows].any(axis=0) & grid[door_rows].any(axis=0)).any():
            continue
        face_grid = closed(plane_raw)
        leaf = replace(frame, grid=face_grid, vu=vu[in_face], vy=vy[in_face])
        for c in _doors(leaf, walls, floor_cols, params):
            # a leaf scanned lower than the wall beside it leaves the band above its scanned top
            # empty in the whole slab, between the door's jambs: a "window" without a head
            # (:func:`_headless_windows`) that the doorway in the face's plane explains
            over = [o for o in found if _overlap(c, o)]
            if any(o.kind != "window" or o.how != "head unseen" or not _same_jambs(c, o, EDGE_CELLS * cell) for o in over):
                continue
            before = len(found)
            if c.how in ("gap", "corner"):
                found.append(replace(c, how="leaf"))
            elif c.how == "head unseen" and _open_in_slab(grid, door_rows, lo, cell, c):
                # a leaf standing open reaches into the slab by its hinge only, a wedge beside
                # one jamb that the face's own plane does not hold: the doorway is open
                found.append(c)
            elif c.how == "head unseen" and _revealed(ev, w, c, (far, near), floor + params.opening_margin_m, floor + HEAD_UNSEEN_MIN_TOP_M):
                # a leaf closed in its frame, or standing a little open with its faces in the
                # slab all over the doorway (a missing strip of the face, with the far face of
                # its wall behind, has no reveals at its edges)
                found.append(replace(c, how="leaf"))
            if len(found) > before and over:
                found = [o for o in found if not any(o is x for x in over)]
    # windows whose glazing was scanned, set back in a reveal: holes in the face's own plane
    # over a surface behind it that faces the room (the wall's far face faces away)
    room = ev.normals[cand][keep] @ n3 > ev.cos
    back = tri[room & (max3(d_kept) < -RECESS_MIN_M)]
    if len(back):
        face = raster(at, near, -RECESS_MIN_M)
        recess = ndimage.binary_closing(raster(cells(_samples(back, cell)), -RECESS_MIN_M, far), structure=np.ones((2, 2))) & ~face
        # the depths of the room-facing surfaces, sampled only for a face with a recess that
        # passes the cheap tests (most faces have none)
        def depth() -> tuple[IntArray, IntArray, FloatArray]:
            pd, flat = cells(_samples(tri[room], cell))
            ok = (pd >= far) & (pd <= near)
            r, c = np.divmod(flat[ok], ncol)
            return r, c, pd[ok]

        found += [c for c in _recesses(frame, face, recess, depth, walls, params) if not any(_overlap(c, o, RECESS_APART_M) for o in found)]
    return found


#: A doorway found in a face's own plane is open (its leaf stands open, reaching into the slab
#: by its hinge only) when at least this share of its columns is empty in the whole slab, from
#: the floor to a door's height; a closed leaf set back in its frame fills them all.
OPEN_IN_SLAB_SHARE = 0.5


#: A doorway found in the face's own plane whose head the scan did not reach, with the whole slab
#: holding something over it (a leaf closed in its frame, or standing a little open), is a door
#: when both its jambs show a reveal: faces across the wall's depth (facing along the wall) within
#: :data:`REVEAL_REACH_M` of each jamb, at heights covering at least this share of the rows (of
#: ``opening_cell_m``) from the floor band up to :data:`HEAD_UNSEEN_MIN_TOP_M`. A strip of the face
#: that the scan missed shows the far face of its wall behind it and has no reveal at its edges (0
#: rows on the hard synthetic scans, 25-35 rows of 5 cm at a door's jambs there).
REVEAL_SHARE = 0.5
#: ... within this distance (m) along the wall of the jamb: the grid's quantization of the jamb
#: (:data:`EDGE_CELLS` cells of 5 cm).
REVEAL_REACH_M = 0.1
#: The reveal of a jamb is read inside the wall's depth, this far (m) from both its faces: a
#: door's leaf standing open at its hinge stands in the doorway beside the reveal, from the face
#: its hinge is on outwards, and reaches into the wall's depth by less than its thickness (4 cm)
#: times the cosine of its angle; its edge then lies in the face's plane, a jamb to the raster
#: (the opening measured a leaf's thickness narrow), while the reveal behind it is the jamb.
REVEAL_INSET_M = 0.02
#: A leaf standing open by 10-35 degrees puts a wedge of its faces into the slab beside its
#: hinge's jamb, off the face's own plane: the slab's raster finds the doorway narrowed by up to
#: this much (m; half the narrowest door, ``door_width_m``), and the reveal beyond the wedge is
#: the jamb ...
LEAF_WEDGE_M = 0.3
#: ... which is a leaf when the slab's samples there lie on a plane (their median distance from
#: the line fitted to them at most this, m: a 4 cm leaf's two faces, 2 cm either side of its
#: middle, and the scan's noise) turned from the face by :data:`LEAF_MIN_TURN_DEG` or more, or
#: stand off the face's plane (farther than this from it).
LEAF_PLANE_M = 0.03
#: A door leaf standing open turns from its wall by at least this angle (degrees); a leaf
#: nearer to closed lies in the wall's plane and is part of the wall's face, or the door's.
LEAF_MIN_TURN_DEG = 10.0


def _reveal(
    ev: WallEvidence, w: int, u: float, d_range: tuple[float, float], low: float, high: float, toward: float = 0.0, reach: float = REVEAL_REACH_M
) -> tuple[float, float]:
    """The reveal at a jamb ``u`` along face ``w``: ``(share, position)``, the share of the rows
    (of ``opening_cell_m``) from ``low`` to ``high`` holding a face across the wall's depth (facing
    along the wall, in ``d_range`` across it, within ``reach`` of ``u``) and the
    area-weighted median position of those faces along the wall (``nan`` without any). With
    ``toward`` (+1 or -1) only the faces facing that way along the tangent count: those facing
    into the opening."""
    walls, cell = ev.walls, ev.params.opening_cell_m
    n3 = np.array([walls.normal[w][0], 0.0, walls.normal[w][1]])
    t3 = np.array([walls.tangent[w][0], 0.0, walls.tangent[w][1]])
    off = float(walls.offset[w])
    nrow = max(1, int(np.ceil((high - low) / cell)))
    box = (u - reach, u + reach)
    faces = ev.near(ev.across(w, d_range, box), n3, t3, off, d_range, box, (low, high))
    if toward:
        faces = faces[ev.normals[faces] @ t3 * toward > 0]
    tri = ev.tri[faces]
    d, y = tri @ n3 - off, tri[:, :, 1]
    cu = ev.centroids[faces] @ t3
    ok = (max3(d) >= d_range[0]) & (min3(d) <= d_range[1]) & (np.abs(cu - u) <= reach)
    ok &= (max3(y) >= low) & (min3(y) <= high)
    if not ok.any():
        return 0.0, float("nan")
    a = np.clip(np.floor((min3(y[ok]) - low) / cell).astype(np.int64), 0, nrow)
    b = np.clip(np.ceil((max3(y[ok]) - low) / cell).astype(np.int64), 0, nrow)
    diff = np.zeros(nrow + 1, np.int64)
    np.add.at(diff, a, 1)
    np.add.at(diff, b, -1)
    share = float(np.mean(np.cumsum(diff)[:nrow] > 0))
    order = np.argsort(cu[ok], kind="stable")
    weight = np.cumsum(ev.mesh.face_areas[faces[ok]][order])
    return share, float(cu[ok][order][np.searchsorted(weight, 0.5 * weight[-1])])


def _local_front(
    at: tuple[FloatArray, IntArray], ncol: int, cell: float, rows: slice, on_face: np.ndarray, far: float, near: float, min_cols: int = 1
) -> FloatArray | None:
    """Each column's depth of the wall's own front across face raster columns (depths ``at``
    as :func:`_gaps` makes them), where the wall beside a closed door's leaf stands at least
    :data:`LEAF_SET_BACK_M` in front of the face's fitted plane over at least ``min_cols``
    consecutive columns of the face; ``None`` where it does not.

    A column's front is the :data:`FRONT_PERCENTILE` th percentile of the depths of its samples
    in ``rows`` (columns ``cell`` wide) (the door's height; the far end of the slab where it holds none, a doorway); the
    wall's front is the front with its dips up to a door's greatest width (plus the raster's
    edge cells) filled from both sides (a grey closing): a leaf set back in its frame is such a
    dip, between the wall on either side.
    """
    pd, flat = at
    sel = (flat >= rows.start * ncol) & (flat < rows.stop * ncol) & (pd >= far) & (pd <= near)
    if not sel.any():
        return None
    # the percentile from each column's histogram of depths in FRONT_BIN_M bins, counted from the
    # front (a sort of the samples cost ten times more)
    n_bins = int(np.ceil((near - far) / FRONT_BIN_M)) + 1
    b = np.minimum(((near - pd[sel]) / FRONT_BIN_M).astype(np.int64), n_bins - 1)  # 0: the front
    hist = np.bincount((flat[sel] % ncol) * n_bins + b, minlength=ncol * n_bins).reshape(ncol, n_bins)
    counts = hist.sum(axis=1)
    has = counts > 0
    reached = np.cumsum(hist, axis=1) > (1.0 - FRONT_PERCENTILE / 100.0) * counts[:, None]
    front = np.where(has, near - (np.argmax(reached, axis=1) + 0.5) * FRONT_BIN_M, far)
    width = int(np.ceil(LEAF_FRONT_SPAN_M / cell))
    wall = ndimage.grey_closing(front, size=width, mode="nearest")
    dip = on_face & has & (wall >= LEAF_SET_BACK_M) & (front <= wall - LEAF_SET_BACK_M)
    # a leaf is a door wide: a shorter dip (a picture frame, a switch) is no reason to search
    if _longest_run(dip) < min_cols:
        return None
    # and set back from the wall's surface, the front most of the wall around it shows, not
    # from furniture standing a few centimetres out of it on both sides (the bare wall between
    # two shelves: office preset, seed 4)
    half = int(np.ceil(WALL_FRONT_SPAN_M / 2 / cell))
    for c in np.flatnonzero(dip):
        around = front[max(c - half, 0) : c + half + 1][has[max(c - half, 0) : c + half + 1]]
        if front[c] > np.median(around) - LEAF_SET_BACK_M:
            dip[c] = False
    return wall if _longest_run(dip) >= min_cols else None


def _longest_run(mask: np.ndarray) -> int:
    """The most consecutive True values of a 1-D boolean ``mask``."""
    if not mask.any():
        return 0
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return int((edges[1::2] - edges[::2]).max())


def _revealed(ev: WallEvidence, w: int, c: Candidate, d_range: tuple[float, float], low: float, high: float) -> bool:
    """Whether both jambs of door ``c`` in face ``w`` show a reveal in the slab ``d_range`` over
    :data:`REVEAL_SHARE` of the heights from ``low`` to ``high`` (see :data:`REVEAL_SHARE`)."""
    return all(_reveal(ev, w, u, d_range, low, high)[0] >= REVEAL_SHARE for u in (c.u_min, c.u_max))


def _same_jambs(a: Candidate, b: Candidate, tol: float) -> bool:
    """Whether two openings of one face have their jambs within ``tol`` (m) of each other."""
    return abs(a.u_min - b.u_min) <= tol and abs(a.u_max - b.u_max) <= tol


def _open_in_slab(grid: np.ndarray, rows: slice, lo: float, cell: float, c: Candidate) -> bool:
    """Whether :data:`OPEN_IN_SLAB_SHARE` of the columns of door ``c`` are empty over ``rows``
    in the whole slab's raster ``grid`` (from ``lo`` along the wall, ``cell`` a column)."""
    a = max(0, int(np.floor((c.u_min - lo) / cell)))
    b = min(grid.shape[1], int(np.ceil((c.u_max - lo) / cell)))
    if b <= a:
        return False
    return bool(np.mean(~grid[rows, a:b].any(axis=0)) >= OPEN_IN_SLAB_SHARE)


def _overlap(a: Candidate, b: Candidate, margin: float = 0.0) -> bool:
    """Whether two openings of one face overlap, or come within ``margin`` (m) of each other."""
    return a.u_min < b.u_max + margin and b.u_min < a.u_max + margin and a.bottom < b.top + margin and b.bottom < a.top + margin


def _step(region: np.ndarray, depth: tuple[IntArray, IntArray, FloatArray]) -> float:
    """How far (m) the surface two cells inside ``region`` (a recess) stands behind the surface
    two cells outside it (its frame): the median depths of the samples ``depth`` (row, column,
    depth) at :data:`RECESS_STEP_CELLS` from its edge on either side; ``-inf`` without samples
    on both."""
    rows, cols = np.nonzero(region)
    pad = RECESS_STEP_CELLS + 1
    r0, c0 = max(int(rows.min()) - pad, 0), max(int(cols.min()) - pad, 0)
    r1, c1 = int(rows.max()) + pad + 1, int(cols.max()) + pad + 1
    box = region[r0:r1, c0:c1]
    inside = ndimage.distance_transform_cdt(box, metric="chessboard")
    outside = ndimage.distance_transform_cdt(~box, metric="chessboard")
    r, c, d = depth
    sel = (r >= r0) & (r < r0 + box.shape[0]) & (c >= c0) & (c < c0 + box.shape[1])
    r, c, d = r[sel] - r0, c[sel] - c0, d[sel]
    glass = d[box[r, c] & (inside[r, c] == RECESS_STEP_CELLS)]
    frame = d[~box[r, c] & (outside[r, c] == RECESS_STEP_CELLS)]
    if not len(glass) or not len(frame):
        return -np.inf
    return float(np.median(frame) - np.median(glass))


def _spread(f: _Frame, recess: np.ndarray, depth: tuple[IntArray, IntArray, FloatArray], walls: FlatWalls) -> float:
    """The face's warp: the robust standard deviation (m) of the depth of the samples ``depth``
    (row, column, depth) within the wall's extent and outside the ``recess`` cells."""
    r, c, d = depth
    u = f.lo + (c + 0.5) * f.cell
    d = d[(u > walls.u_min[f.wall]) & (u < walls.u_max[f.wall]) & ~recess[r, c]]
    if not len(d):
        return 0.0
    return float(MAD_TO_SIGMA * np.median(np.abs(d - np.median(d))))


def _recesses(
    f: _Frame,
    face: np.ndarray,
    recess: np.ndarray,
    depth_of: Callable[[], tuple[IntArray, IntArray, FloatArray]],
    walls: FlatWalls,
    params: PlanParams,
) -> list[Candidate]:
    """Windows whose glazing (a blind, a lattice) was scanned in a reveal: each region of
    ``recess`` (cells where a surface facing the room stands back behind the face, and the face
    itself was not scanned) of a window's size and shape, above a sill, and framed by the face
    (``face``: cells where the face's plane was scanned) on :data:`RECESS_FRAME_SHARE` of each
    of its four sides, with a step at its edge (:func:`_step`) of at least
    :data:`RECESS_STEP_M` and :data:`RECESS_STEP_SPREAD` times the face's warp (:func:`_spread`).

    Parameters
    ----------
    f
        The face's raster and frame.
    face, recess
        ``(nrow, ncol)`` cells of the face's plane and of surfaces set back behind it.
    depth_of
        Gives ``(rows, cols, depths)`` of the samples of the room-facing surfaces in the face's
        slab (called once, for the first recess that passes the tests of size and frame).
    walls, params
        The walls (the face's extent) and the size limits of windows.

    Returns
    -------
    The windows found, ``how="recess"``.
    """
    cell, lo, floor = f.cell, f.lo, f.floor
    nrow, ncol = recess.shape
    labels, n = ndimage.label(recess)
    if n == 0:
        return []
    framed = ndimage.binary_dilation(face, structure=np.ones((3, 3)))
    tol = EDGE_CELLS * cell
    spread: float | None = None  # the face's warp, measured when a recess needs it
    out = []
    for k, (rs, cs) in enumerate(ndimage.find_objects(labels), start=1):
        left, right = lo + cs.start * cell, lo + cs.stop * cell
        low, high = floor + rs.start * cell, floor + rs.stop * cell
        width, height = right - left, high - low
        if left < walls.u_min[f.wall] + tol or right > walls.u_max[f.wall] - tol:
            continue  # a window set back in a wall has the wall on both sides of it
        if not (params.window_width_m[0] <= width <= params.window_width_m[1]) or height < params.window_height_m or width * height < params.window_area_m2:
            continue
        if low - floor < params.window_sill_m or high > f.ceiling - params.opening_margin_m:
            continue
        if (labels[rs, cs] == k).mean() < RECESS_FILL:
            continue
        # the frame: the face's plane scanned along each of the four sides, just outside
        below, above = framed[rs.start - 1, cs] if rs.start > 0 else np.zeros(0), framed[rs.stop, cs] if rs.stop < nrow else np.zeros(0)
        before, after = framed[rs, cs.start - 1] if cs.start > 0 else np.zeros(0), framed[rs, cs.stop] if cs.stop < ncol else np.zeros(0)
        if min((float(side.mean()) if side.size else 0.0) for side in (below, above, before, after)) < RECESS_FRAME_SHARE:
            continue  # no frame in the wall's plane all round: a recessed piece of wall, a niche, a desk's knee space
        if spread is None:
            depth = depth_of()
            spread = _spread(f, recess, depth, walls)
        step = _step(labels == k, depth)
        if step < max(RECESS_STEP_M, RECESS_STEP_SPREAD * spread):
            continue  # no step at its edge, or none the face's own warp cannot make: not a reveal
        out.append(Candidate("window", f.wall, left, right, low, high, "recess"))
    return out


@dataclass(frozen=True)
class _Frame:
    """One face's raster (``grid[row, col]``: wall in the cell) and the triangle corners in its
    slab (``vu``, ``vy``), from ``lo`` along the wall and ``floor`` up."""

    grid: np.ndarray
    lo: float
    floor: float
    ceiling: float
    cell: float
    margin: int
    vu: FloatArray
    vy: FloatArray
    wall: int
    left_corner: bool
    right_corner: bool
    #: moves a door's jambs out to the reveals beyond them, where the wall's depth is known
    to_reveals: Callable[[float, float], tuple[float, float]] | None = None


def _refine(f: _Frame, left: float, right: float, low: float, high: float) -> tuple[float, float]:
    """The jambs of an opening at the triangle corners next to its grid edges."""
    tol = EDGE_CELLS * f.cell
    band = (f.vy > low + tol) & (f.vy < high - tol)
    mid = 0.5 * (left + right)
    lv = f.vu[band & (f.vu <= mid) & (f.vu >= left - tol)]
    rv = f.vu[band & (f.vu >= mid) & (f.vu <= right + tol)]
    return (float(lv.max()) if len(lv) else left), (float(rv.min()) if len(rv) else right)


def _in_line(walls: FlatWalls, w: int, u: float, collinear_m: float, reach_m: float) -> bool:
    """Whether another wall face of ``w``'s story lies in its line at ``u`` along it: either side
    of the wall (facing the same way or the other), its plane within ``collinear_m`` plus
    :data:`MAX_DOOR_WALL_M` of ``w``'s either way, reaching ``u`` within ``reach_m`` (``door_corner_m``:
    scans lose the strip of wall beside a door's frame as they round off a corner)."""
    n, t = walls.normal[w], walls.tangent[w]
    same = (walls.story == walls.story[w]) & (np.abs(walls.normal @ n) >= np.cos(np.radians(COLLINEAR_DOOR_DEG)))
    same[w] = False
    if not same.any():
        return False
    k = np.flatnonzero(same)
    # each face's plane in w's frame: n . p = offset (a face turned the other way: -offset)
    sign = np.sign(walls.normal[k] @ n)
    plane = sign * walls.offset[k]
    near_plane = np.abs(plane - walls.offset[w]) <= collinear_m + MAX_DOOR_WALL_M
    ends = np.stack([walls.start[k] @ t, walls.end[k] @ t], axis=1)
    reach = (ends.min(axis=1) - reach_m <= u) & (u <= ends.max(axis=1) + reach_m)
    return bool(np.any(near_plane & reach))


def _doors(f: _Frame, walls: FlatWalls, floor_cols: np.ndarray, params: PlanParams) -> list[Candidate]:
    """Doors: runs of columns empty from the floor up to a door's height, between jambs.

    Read column by column rather than as empty regions, so that a doorway stays a doorway
    where its empty space runs on into a scan hole above the lintel or along the top of the
    wall.
    """
    g, cell, m = f.grid, f.cell, f.margin
    nrow, ncol = g.shape
    tol = EDGE_CELLS * cell
    body = g[m : nrow - m]
    if not body.shape[0]:
        return []
    filled: np.ndarray = np.asarray(body.any(axis=0))
    # empty rows from the floor band up, per column, and whether anything is above them
    first = np.where(filled, np.argmax(body, axis=0), body.shape[0])
    head = f.floor + (m + first) * cell  # where the column's empty space from the floor ends
    col_top: FloatArray = f.floor + (_wall_tops(g, m) + 1).astype(np.float64) * cell  # highest wall in it (the floor in none)
    tall = head >= f.floor + params.door_height_m - tol
    low_wall = first * cell <= 0.5 * params.door_height_m  # wall (a jamb) from near the floor
    out = []
    c = 0
    while c < ncol:
        if not tall[c]:
            c += 1
            continue
        c0 = c
        while c < ncol and tall[c]:
            c += 1
        c1 = c  # the run is [c0, c1)
        # jambs: a column of wall from near the floor within a few cells on each side
        lj = [k for k in range(c0 - 1, max(c0 - 1 - EDGE_CELLS, -1), -1) if low_wall[k]]
        rj = [k for k in range(c1, min(c1 + EDGE_CELLS, ncol)) if low_wall[k]]
        if c0 == 0 or c1 == ncol or not lj or not rj:
            continue
        left, right = f.lo + (lj[0] + 1) * cell, f.lo + rj[0] * cell
        if right < walls.u_min[f.wall] - tol or left > walls.u_max[f.wall] + tol:
            continue  # wholly beyond this face: another face's search finds it
        if not params.door_width_m[0] - 2 * tol <= right - left <= params.door_width_m[1] + 2 * tol:
            continue
        # a gap running past the end of this face is a door only between two pieces of wall:
        # its far jamb on another face in this wall's line, or a corner (not a cupboard's side,
        # a counter's end or clutter standing in the line)
        if (left < walls.u_min[f.wall] - tol and not f.left_corner and not _in_line(walls, f.wall, left, params.collinear_wall_m, params.door_corner_m)) or (
            right > walls.u_max[f.wall] + tol and not f.right_corner and not _in_line(walls, f.wall, right, params.collinear_wall_m, params.door_corner_m)
        ):
            continue
        run = slice(lj[0] + 1, rj[0])
        closed = np.asarray(filled[run] & (head[run] < f.ceiling - params.opening_margin_m))
        how = "gap"
        if closed.mean() >= params.opening_edge_straightness:
            heads = head[run][closed]
            top = float(np.median(heads))
            if np.mean(np.abs(heads - top) <= tol) < params.opening_edge_straightness:
                continue  # a ragged top: a hole in the scan, not a lintel
        elif closed.mean() <= 1.0 - params.opening_edge_straightness:
            # no lintel scanned (a few columns may hold a speck: a stray triangle, the edge of a
            # leaf standing open), and the floor runs on through the gap beyond the wall: either
            # the wall beside the gap rises above any door head (the scan missed the lintel),
            # or the jambs rise as high as the wall beside them was scanned, above the work
            # surfaces (the head is in the unscanned band over the wall's top)
            if floor_cols[run].mean() < params.door_floor_beyond:
                continue
            # each jamb's top: the highest of the columns of wall from near the floor among its
            # column and the EDGE_CELLS beside it in the wall, not the column nearest the gap
            # alone, which may hold only the edge of a leaf standing at the hinge (hard seed 9: a
            # leaf nearly closed, its edge 0.8 m high beside a jamb scanned to 1.55 m); columns
            # holding nothing near the floor (specks high up) are no jamb
            jamb_top = min(
                np.max(np.where(low_wall, col_top, f.floor)[max(lj[0] - EDGE_CELLS, 0) : lj[0] + 1]),
                np.max(np.where(low_wall, col_top, f.floor)[rj[0] : rj[0] + EDGE_CELLS + 1]),
            )
            if jamb_top >= min(f.floor + DOOR_HEAD_MAX_M, f.ceiling - params.opening_margin_m - tol):
                top, how = f.ceiling, "no lintel"
            elif jamb_top - f.floor >= HEAD_UNSEEN_MIN_TOP_M and _jambs_reach_wall_top(f, col_top, lj[0], rj[0]):
                top, how = min(f.ceiling, f.floor + DOOR_HEAD_ASSUMED_M), "head unseen"
            else:
                continue
        else:
            continue
        left, right = _refine(f, left, right, f.floor + params.opening_margin_m, min(top, f.floor + params.door_height_m))
        if f.to_reveals is not None:
            left, right = f.to_reveals(left, right)
        if not params.door_width_m[0] <= right - left <= params.door_width_m[1]:
            continue
        if (f.left_corner and lj[0] < EDGE_CELLS) or (f.right_corner and rj[0] >= ncol - EDGE_CELLS):
            how = "corner"
        across = (f.vu > left + tol) & (f.vu < right - tol)
        tv = f.vy[across & (f.vy >= top - tol) & (f.vy <= top + tol)]
        if how not in ("no lintel", "head unseen") and len(tv):
            top = float(tv.min())
        if how not in ("no lintel", "head unseen") and top > f.floor + DOOR_HEAD_MAX_M:
            continue  # a lintel higher than any door's head
        out.append(Candidate("door", f.wall, left, right, f.floor, top, how))
    return out


#: Cells (of ``opening_cell_m``) a jamb of a doorway whose head was not scanned may stop below
#: the wall's scanned top beside it (:func:`_jambs_reach_wall_top`): the scan's top steps by up
#: to 15 cm from one piece of wall to the next (the hard synthetic scans' pieces stop at 1.4-2.0 m
#: at random; a door's jamb piece 15 cm lower than the next piece is common there), while the
#: jambs of a hole in the scan stop 40 cm and more below the wall around it.
JAMB_TOP_CELLS = 4

#: A jamb also reaches the wall's scanned top (:func:`_jambs_reach_wall_top`) when the wall
#: beside it holds the jamb's top, within :data:`JAMB_TOP_CELLS`, over at least this length (m)
#: from the gap: the piece of wall the jamb belongs to was scanned as high as the jamb, though the
#: next piece was scanned higher (hard seed 6: an entrance door's jamb piece, 0.45 m long, stops
#: at 1.45 m and the wall beyond it at 1.8 m, which set the median of the metre beside the
#: jamb). The edge of a hole in the scan climbs to the wall's top over a few cells; it holds no
#: level top this long.
JAMB_LEVEL_M = 0.4


def _jambs_reach_wall_top(f: _Frame, col_top: FloatArray, left: int, right: int) -> bool:
    """Whether the wall at each jamb (the highest of the columns ``left`` and ``right`` and the
    :data:`EDGE_CELLS` next to them in the wall, for the rounded or decimated corner of a jamb)
    rises within :data:`JAMB_TOP_CELLS` cells of the top of the wall scanned beside it (the median
    top of the columns within :data:`HEAD_UNSEEN_CONTEXT_M` on its side, the columns a corner
    closes left out: a ragged top scatters by a few cells), or holds its top level along the wall
    for :data:`JAMB_LEVEL_M`: the gap's edges are the wall's full scanned height, not a hole
    lower in it."""
    k = max(1, int(np.ceil(HEAD_UNSEEN_CONTEXT_M / f.cell)))
    first = EDGE_CELLS if f.left_corner else 0
    stop = len(col_top) - EDGE_CELLS if f.right_corner else len(col_top)
    tol = JAMB_TOP_CELLS * f.cell

    def tops(a: int, b: int) -> FloatArray:
        return col_top[max(a, first) : min(b, stop)]

    level = max(1, int(np.ceil(JAMB_LEVEL_M / f.cell - 1e-9)))

    def reaches(jamb: FloatArray, beside: FloatArray, outward: FloatArray) -> bool:
        if not (len(jamb) and len(beside)):
            return False
        top = jamb.max()
        if top >= np.median(beside) - tol:
            return True
        # the columns from the gap outward, as long as they stay level with the jamb's top
        held = np.abs(outward - top) <= tol
        return bool(len(held) >= level and held[:level].all())

    return reaches(tops(left - EDGE_CELLS, left + 1), tops(left - k, left + 1), tops(left - level + 1, left + 1)[::-1]) and reaches(
        tops(right, right + EDGE_CELLS + 1), tops(right, right + k + 1), tops(right, right + level)
    )


def _windows(f: _Frame, walls: FlatWalls, params: PlanParams) -> list[Candidate]:
    """Windows: empty regions with wall below (a sill), above (a head) and beside them, and
    straight edges all round."""
    empty = ~f.grid
    return _with_ragged_windows(f, walls, params, empty, _window_regions(f, walls, params, empty))


def _with_ragged_windows(f: _Frame, walls: FlatWalls, params: PlanParams, empty: np.ndarray, found: list[Candidate]) -> list[Candidate]:
    """``found`` and the windows whose empty region a scan hole made ragged.

    A scan hole running into a window's frame (its head, a jamb, the sill beside a jamb) joins
    the window's empty region, which is then neither a rectangle nor straight-edged: the window
    is the largest rectangle of empty cells in the region, held to the same tests and framed by
    wall along three of its four sides at least (a hole hides part of one side of a frame; the
    largest rectangle in a ragged hole has the rest of the hole beyond two or more of its
    sides)."""
    nrow, ncol = f.grid.shape
    labels, _ = ndimage.label(empty)
    cores = np.zeros_like(empty)
    # (a region too small to hold a window's rectangle is a scan hole: most are, and the
    # rectangle search runs cell by cell)
    least_cols = int(np.floor((params.window_width_m[0] - 2 * EDGE_CELLS * f.cell) / f.cell))
    least_rows = int(np.floor(params.window_height_m / f.cell))
    for k, (rs, cs) in enumerate(ndimage.find_objects(labels), start=1):
        if cs.start == 0 or cs.stop == ncol or rs.start <= f.margin or rs.stop >= nrow - f.margin:
            continue  # no window whatever its shape (see _window_regions)
        if cs.stop - cs.start < least_cols or rs.stop - rs.start < least_rows:
            continue
        r0, r1, c0, c1 = _largest_rectangle(labels[rs, cs] == k)
        cores[rs.start + r0 : rs.start + r1, cs.start + c0 : cs.start + c1] = True
    if cores.any():
        ragged = [replace(c, ragged=True) for c in _window_regions(f, walls, params, cores, framed_sides=3)]
        found = found + [c for c in ragged if not any(_overlap(c, o) for o in found)]
    return found


#: Head given to a window whose head was not scanned (m above its floor): the line of the door
#: heads, where most window heads stand (2.0-2.2 m).
WINDOW_HEAD_ASSUMED_M = 2.1
#: Share of a window's width that lies over its face's extent: the wall under a sill and over a
#: head is the face's own plane, merged into one face with the wall beside the window, so that
#: a window lies within its face; the reach beyond a face's ends is for doors, which split the
#: wall to the floor (a face ends at each of their jambs). The empty space between the shelves
#: of a bookcase or beside the end of a short furniture face is no window (hard preset, seed 4:
#: a 0.4 m face holding two stacked "windows" 1 m wide, 0.4 m of each over it).
WINDOW_IN_FACE_SHARE = 0.5


def _headless_windows(f: _Frame, walls: FlatWalls, params: PlanParams) -> list[Candidate]:
    """Windows in a face scanned only up to a height below its ceiling (the unscanned band above
    it, :data:`HEAD_UNSEEN_MIN_TOP_M`): the band above the face's scanned top (the median top of
    its columns) is taken as wall, so that a window whose head stands in it shows as an empty
    rectangle from its sill up to where the scan stopped, framed by straight jambs and a sill
    (:func:`_window_regions`); its head is assumed (:data:`WINDOW_HEAD_ASSUMED_M`)."""
    g, cell, m = f.grid, f.cell, f.margin
    nrow, ncol = g.shape
    tops = _wall_tops(g, m)
    col_u = f.lo + (np.arange(ncol) + 0.5) * cell
    filled = (tops >= 0) & (col_u >= walls.u_min[f.wall]) & (col_u <= walls.u_max[f.wall])
    if not filled.any():
        return []
    top_row = int(np.median(tops[filled] - m)) + m  # the last row of wall, in grid rows
    scanned_top = f.floor + (top_row + 1) * cell
    if scanned_top >= f.ceiling - params.opening_margin_m - EDGE_CELLS * cell or scanned_top - f.floor < HEAD_UNSEEN_MIN_TOP_M:
        return []
    grid = g.copy()
    grid[top_row + 1 :] = True  # the unscanned band: wall, as far as a window is concerned
    banded, empty = replace(f, grid=grid), _tall_runs(~grid, f.cell, params)
    out = []
    for c in _with_ragged_windows(banded, walls, params, empty, _window_regions(banded, walls, params, empty)):
        if c.top >= scanned_top - EDGE_CELLS * cell:  # up to where the scan stopped
            out.append(replace(c, top=max(c.top, f.floor + WINDOW_HEAD_ASSUMED_M), how="head unseen"))
    return out


def _notch_windows(f: _Frame, walls: FlatWalls, params: PlanParams) -> list[Candidate]:
    """Windows in a face scanned only up to heights below its ceiling that vary along it (the
    scan's top steps from one piece of wall to the next, so that the face's median top of
    :func:`_headless_windows` cuts through the pieces beside a window): each column's unscanned
    space above the lower of the highest columns within the widest window on either side (the
    jambs' tops) is taken as wall, so that a window whose head stands in it shows as an empty
    rectangle from its sill up to the lower jamb's top, framed by straight jambs and a sill
    (:func:`_window_regions`). Its sill lies no higher than :data:`HEAD_UNSEEN_MIN_TOP_M` (a
    piece of wall scanned lower than those beside it, higher up, is where the scan stopped), its
    jambs rise above that and stop below the ceiling; its head is assumed
    (:data:`WINDOW_HEAD_ASSUMED_M`)."""
    g, cell, m = f.grid, f.cell, f.margin
    nrow, ncol = g.shape
    col_u = f.lo + (np.arange(ncol) + 0.5) * cell
    top_rows = _wall_tops(g, m)  # the last row of wall
    if not ((top_rows >= 0) & (col_u >= walls.u_min[f.wall]) & (col_u <= walls.u_max[f.wall])).any():
        return []
    # the columns a corner closes (:func:`_gaps`) stand for the perpendicular wall, not for how
    # high this one was scanned: taken as jambs' tops, they raised the cap of every column
    # within a window's width of the corner to the raster's top (hard preset, seed 4: two
    # windows next to a corner joined over their pier into one region 1 m tall)
    if f.left_corner:
        top_rows[:EDGE_CELLS] = -1
    if f.right_corner:
        top_rows[ncol - EDGE_CELLS :] = -1
    k = int(np.ceil(params.window_width_m[1] / cell))
    # a column with nothing scanned (a hole, a doorway) is capped by the highest column within
    # k columns on each side (itself included), the lower side's: it stays as open as the wall
    # around it was scanned, and joins what it touches; a scanned column by its jambs
    left = ndimage.maximum_filter1d(top_rows, size=k + 1, origin=k // 2, mode="nearest")
    right = ndimage.maximum_filter1d(top_rows, size=k + 1, origin=-(k // 2) - (k % 2), mode="nearest")
    cap = np.where(top_rows >= 0, _jamb_caps(top_rows, int(np.ceil(params.window_height_m / cell - 1e-9)), k), np.minimum(left, right))
    grid = g.copy()
    grid[np.arange(nrow)[:, None] > cap[None, :]] = True
    out = []
    for c in _window_regions(replace(f, grid=grid), walls, params, _tall_runs(~grid, f.cell, params)):
        if c.bottom > f.floor + HEAD_UNSEEN_MIN_TOP_M:
            continue
        a = int(np.clip(np.floor((c.u_min - f.lo) / cell), 0, ncol - 1))
        b = int(np.clip(np.ceil((c.u_max - f.lo) / cell), a + 1, ncol))
        # the lower jamb's top: the highest of the EDGE_CELLS columns beside the notch on each
        # side (its own columns' caps may be their own tops, where specks high up in a slot
        # scanned nowhere else found no jamb above them: a full-height strip missing from a wall
        # read as a notch up to the specks)
        jambs = (top_rows[max(a - EDGE_CELLS, 0) : a], top_rows[b : b + EDGE_CELLS])
        if not (len(jambs[0]) and len(jambs[1])):
            continue
        scanned_top = f.floor + (int(min(jambs[0].max(), jambs[1].max())) + 1) * cell
        if scanned_top >= f.ceiling - params.opening_margin_m - EDGE_CELLS * cell or scanned_top - f.floor < HEAD_UNSEEN_MIN_TOP_M:
            continue  # jambs scanned to the ceiling (the head would show), or no higher than the work surfaces
        if c.top >= scanned_top - EDGE_CELLS * cell:  # up to where the scan stopped
            out.append(replace(c, top=max(c.top, f.floor + WINDOW_HEAD_ASSUMED_M), how="head unseen"))
    return out


def _tall_runs(empty: np.ndarray, cell: float, params: PlanParams) -> np.ndarray:
    """The cells of ``empty`` in an upright run of empty cells at least ``window_height_m``
    tall (a binary opening by an upright line).

    Where the head of a window was not scanned, the space above the wall's scanned top is taken
    as wall up to the same height everywhere (:func:`_headless_windows`) or up to the jambs'
    tops (:func:`_notch_windows`), while pieces of wall beside a window, or the pier between two
    windows, were scanned to 5-15 cm lower: the strips of empty cells over them joined the
    windows' regions to each other and to the wall's top, so that none was a rectangle (hard
    preset, seed 5: two kitchen windows and their pier). A window is empty over its whole
    height in each of its columns, at least ``window_height_m`` (shorter regions are refused
    anyway), so dropping the shorter runs loses no window's cell.
    """
    rows = int(np.ceil(params.window_height_m / cell - 1e-9))
    if rows <= 1 or not empty.any():
        return empty
    return ndimage.binary_opening(empty, structure=np.ones((rows, 1), dtype=bool))


def _wall_tops(grid: np.ndarray, margin: int) -> IntArray:
    """Each column's last row of wall (in ``grid``'s rows) between the ``margin`` rows closed at
    the floor and at the ceiling; -1 where the column holds none."""
    body = grid[margin : grid.shape[0] - margin]
    if not body.shape[0]:
        return np.full(grid.shape[1], -1, dtype=np.int64)
    return np.where(body.any(axis=0), body.shape[0] - 1 - np.argmax(body[::-1], axis=0) + margin, -1)


def _jamb_caps(top_rows: IntArray, rise: int, reach: int) -> IntArray:
    """Each column's cap for :func:`_notch_windows`: the top row of the lower of its jambs, the
    nearest column on either side within ``reach`` columns whose top stands at least ``rise``
    rows above its own (a piece of wall beside a notch); its own top where a side has none (no
    notch there). Unfilled columns (``-1``) are no jamb, and get no cap here (``-1``).

    The nearest such column, not the highest within ``reach`` (a window's greatest width): a
    piece of wall scanned higher farther along (1.75-1.95 m beside jambs scanned to 1.4 m) raised
    the cap above the jambs, so that the notch's empty space ran on over them and was no
    rectangle (hard preset, seed 12: a bathroom window)."""
    n = len(top_rows)
    caps = []
    for step in (1, -1):  # the jamb on the left (columns before), then on the right
        cap = np.full(n, -1, dtype=np.int64)
        found = np.zeros(n, dtype=bool)
        for d in range(1, min(reach, n - 1) + 1):
            other = np.full(n, -1, dtype=np.int64)
            if step > 0:
                other[d:] = top_rows[:-d]
            else:
                other[:-d] = top_rows[d:]
            hit = ~found & (top_rows >= 0) & (other >= top_rows + rise)
            cap[hit] = other[hit]
            found |= hit
        caps.append(np.where(found, cap, -1))
    both = (caps[0] >= 0) & (caps[1] >= 0)
    return np.where(both, np.minimum(caps[0], caps[1]), top_rows)


def _largest_rectangle(box: np.ndarray) -> tuple[int, int, int, int]:
    """``(r0, r1, c0, c1)``: the largest axis-aligned rectangle of True cells in ``box``
    (rows ``[r0, r1)``, columns ``[c0, c1)``; the first in order of left column, bottom row
    and width among equals). Each cell's run of True cells upward, then, for each left column,
    the running minimum of those runs to its right: a loop over rows and one over columns, each
    step over whole arrays."""
    nrow, ncol = box.shape
    up = np.zeros((nrow, ncol), np.int64)  # True cells upward from each cell, itself included
    run = np.zeros(ncol, np.int64)
    for r in range(nrow):
        run = np.where(box[r], run + 1, 0)
        up[r] = run
    best, out = 0, (0, 0, 0, 0)
    for c0 in range(ncol):
        height = np.minimum.accumulate(up[:, c0:], axis=1)  # (nrow, widths): the tallest fit
        area = height * np.arange(1, ncol - c0 + 1)
        k = int(np.argmax(area))
        if area.flat[k] > best:
            r, w = divmod(k, ncol - c0)
            best, out = int(area.flat[k]), (r + 1 - int(height[r, w]), r + 1, c0, c0 + w + 1)
    return out


def _framed_sides(grid: np.ndarray, rs: slice, cs: slice, share: float) -> int:
    """How many of the four sides just outside the box ``rs`` x ``cs`` of ``grid`` are wall
    (filled cells) along at least ``share`` of their length."""
    nrow, ncol = grid.shape
    sides = (
        grid[rs.start - 1, cs] if rs.start > 0 else np.zeros(0, bool),
        grid[rs.stop, cs] if rs.stop < nrow else np.zeros(0, bool),
        grid[rs, cs.start - 1] if cs.start > 0 else np.zeros(0, bool),
        grid[rs, cs.stop] if cs.stop < ncol else np.zeros(0, bool),
    )
    return sum(bool(side.size) and float(side.mean()) >= share for side in sides)


def _window_regions(f: _Frame, walls: FlatWalls, params: PlanParams, empty: np.ndarray, framed_sides: int = 0) -> list[Candidate]:
    """The windows among the regions of ``empty`` cells of face raster ``f`` (see :func:`_windows`),
    each framed by wall along at least ``framed_sides`` of its sides (:func:`_framed_sides`)."""
    grid, lo, floor, cell, margin = f.grid, f.lo, f.floor, f.cell, f.margin
    ceiling, vu, vy, w = f.ceiling, f.vu, f.vy, f.wall
    nrow, ncol = grid.shape
    labels, n = ndimage.label(empty)
    if n == 0:
        return []
    out = []
    tol = EDGE_CELLS * cell
    for k, sl in enumerate(ndimage.find_objects(labels), start=1):
        rs, cs = sl
        if cs.start == 0 or cs.stop == ncol:
            continue  # open to the end of the searched line: no jamb there
        box = labels[sl] == k
        if box.mean() < params.opening_rectangularity:
            continue
        left, right = lo + cs.start * cell, lo + cs.stop * cell
        low, high = floor + rs.start * cell, floor + rs.stop * cell
        if min(right, walls.u_max[w] + tol) - max(left, walls.u_min[w] - tol) < WINDOW_IN_FACE_SHARE * (right - left):
            continue  # (mostly) beyond this face: no wall of it under a sill there
        width = right - left
        touches_floor = rs.start <= margin
        reaches_top = rs.stop >= nrow - margin
        window_wide = params.window_width_m[0] - 2 * tol <= width <= params.window_width_m[1] + 2 * tol
        if touches_floor or reaches_top or not window_wide or low - floor < params.window_sill_m - cell or high - low < params.window_height_m:
            continue
        if not (_straight(box, WINDOW_EDGE_CELLS, params.opening_edge_straightness) and _straight(box.T, WINDOW_EDGE_CELLS, params.opening_edge_straightness)):
            continue  # a ragged hole in the scan
        if framed_sides and _framed_sides(grid, rs, cs, params.opening_edge_straightness) < framed_sides:
            continue  # the largest rectangle in a ragged hole: the hole runs on beyond two or more sides
        kind = "window"
        # refine the edges from the triangle corners next to them
        band = (vy > low + tol) & (vy < min(high, ceiling - params.opening_margin_m) - tol)
        mid = 0.5 * (left + right)
        lv = vu[band & (vu <= mid) & (vu >= left - tol)]
        rv = vu[band & (vu >= mid) & (vu <= right + tol)]
        left = float(lv.max()) if len(lv) else left
        right = float(rv.min()) if len(rv) else right
        across = (vu > left + tol) & (vu < right - tol)
        tv_ = vy[across & (vy >= 0.5 * (low + high)) & (vy <= high + tol)]
        top = float(tv_.min()) if len(tv_) else high
        bv = vy[across & (vy <= 0.5 * (low + high)) & (vy >= low - tol)]
        bottom = float(bv.max()) if len(bv) else low
        if not (params.window_width_m[0] <= right - left <= params.window_width_m[1]) or (right - left) * (top - bottom) < params.window_area_m2:
            continue
        out.append(Candidate(kind, w, left, right, bottom, top, "gap"))
    return out


def _floor_beyond(
    ev: WallEvidence, w: int, n3: FloatArray, t3: FloatArray, off: float, floor: float, lo: float, ncol: int, cell: float, params: PlanParams
) -> np.ndarray:
    """``(ncol,)`` whether floor was scanned behind the face (through the wall) in each column."""
    behind = (-FLOOR_BEYOND_M, -params.opening_slab_m)
    along = (lo, lo + ncol * cell)
    f = ev.near(ev.floor_faces(w, floor, behind, along), n3, t3, off, behind, along, (floor - FLOOR_BAND_M, floor + FLOOR_BAND_M))
    out = np.zeros(ncol, dtype=bool)
    if not len(f):
        return out
    tri = ev.tri[f]
    d = tri @ n3 - off
    f_ok = (np.abs(ev.centroids[f, 1] - floor) <= FLOOR_BAND_M) & (max3(d) >= -FLOOR_BEYOND_M) & (min3(d) <= -params.opening_slab_m)
    if not np.any(f_ok):
        return out
    u = tri[f_ok] @ t3
    a = np.clip(np.floor((min3(u) - lo) / cell).astype(np.int64), 0, ncol)
    b = np.clip(np.ceil((max3(u) - lo) / cell).astype(np.int64), 0, ncol)
    # columns covered by a floor triangle: a difference array over the triangles' spans
    diff = np.zeros(ncol + 1, np.int64)
    np.add.at(diff, a, 1)
    np.add.at(diff, b, -1)
    out = np.cumsum(diff)[:ncol] > 0
    return ndimage.binary_closing(out, structure=np.ones(3), border_value=1)


def _panels(ev: WallEvidence, w: int, floor: float, ceiling: float) -> list[Candidate]:
    """Separate door and window boxes or quads of a parametric model lying in face ``w``'s slab."""
    params, walls = ev.params, ev.walls
    faces, starts = ev.panels()
    if len(starts) < 2:
        return []
    cell = params.opening_cell_m
    tol = EDGE_CELLS * cell
    n3 = np.array([walls.normal[w][0], 0.0, walls.normal[w][1]])
    t3 = np.array([walls.tangent[w][0], 0.0, walls.tangent[w][1]])
    off = float(walls.offset[w])
    near, far = params.opening_slab_m, -(params.opening_wall_depth_m + params.opening_slab_m)
    tri = ev.tri[faces]
    d = (tri @ n3 - off).reshape(len(faces), 3)
    u = (tri @ t3).reshape(len(faces), 3)
    y = tri[:, :, 1]
    seg = starts[:-1]
    dmin, dmax = np.minimum.reduceat(min3(d), seg), np.maximum.reduceat(max3(d), seg)
    umin, umax = np.minimum.reduceat(min3(u), seg), np.maximum.reduceat(max3(u), seg)
    ymin, ymax = np.minimum.reduceat(min3(y), seg), np.maximum.reduceat(max3(y), seg)
    width = umax - umin
    in_slab = (dmin >= far) & (dmax <= near) & (umin >= walls.u_min[w] - tol) & (umax <= walls.u_max[w] + tol)
    doors = (
        (ymin <= floor + params.opening_margin_m)
        & (ymax - floor >= params.door_height_m - tol) & (ymax <= ceiling - params.opening_margin_m)
        & (width >= params.door_width_m[0]) & (width <= params.door_width_m[1])
    )
    area = ev.mesh.face_areas[faces]
    largest = np.maximum.reduceat(area, seg)
    # a door panel is a modelled primitive too (a box's or a quad's few triangles): a separate
    # fragment of a scan in the wall's slab (a wardrobe's end, a strip of wall cut off by a
    # missing seam, a decimated piece of a couple of hundred triangles) is not a door
    doors &= largest >= PANEL_PRIMITIVE_SHARE * width * (ymax - ymin)
    windows = (
        (np.abs(0.5 * (dmin + dmax)) <= PANEL_PLANE_M) & (dmax - dmin <= PANEL_THICKNESS_M)
        & (ymin >= floor + PANEL_SILL_MIN_M) & (ymax <= ceiling - params.opening_margin_m)
        & (ymax - ymin >= params.window_height_m)
        & (width >= params.window_width_m[0]) & (width <= params.window_width_m[1])
        & (width * (ymax - ymin) >= params.window_area_m2)
        & (largest >= PANEL_PRIMITIVE_SHARE * width * (ymax - ymin))
    )
    out = []
    for i in np.flatnonzero(in_slab & (doors | windows)):
        fi = faces[starts[i] : starts[i + 1]]
        along = np.abs(ev.normals[fi] @ n3) >= ev.cos
        if not np.any(along):
            continue
        pts = _samples(ev.tri[fi[along]], cell)
        nc = max(1, int(np.ceil(width[i] / cell)))
        nr = max(1, int(np.ceil((ymax[i] - ymin[i]) / cell)))
        cc = np.clip(np.floor((pts @ t3 - umin[i]) / cell).astype(np.int64), 0, nc - 1)
        rr = np.clip(np.floor((pts[:, 1] - ymin[i]) / cell).astype(np.int64), 0, nr - 1)
        g = np.zeros((nr, nc), dtype=bool)
        g[rr, cc] = True
        if g.mean() < PANEL_COVERAGE:
            continue
        if doors[i]:
            out.append(Candidate("door", w, float(umin[i]), float(umax[i]), floor, float(ymax[i]), "panel"))
        else:
            out.append(Candidate("window", w, float(umin[i]), float(umax[i]), float(ymin[i]), float(ymax[i]), "panel"))
    return out
