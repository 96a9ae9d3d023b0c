"""Making the normals face into the rooms.

Scans disagree on winding: some face their normals into the room, some out of it, some mix
both from one connected patch to the next. With the levels known, winding can be read from the
floors (whose normals must point up) and the ceilings (down). Each connected component of the
mesh is flipped when its floor and ceiling faces say it faces out; a component without floor or
ceiling faces follows the majority of the mesh.
"""

from __future__ import annotations

import numpy as np

from ..geometry import FloatArray, IntArray, Mesh
from .params import FACING_HORIZONTAL_DEG, FACING_VERTICAL_DEG
from .stories import Story


def face_components(faces: IntArray, n_vertices: int) -> IntArray:
    """Connected component of every face (faces sharing a vertex are connected).

    Components are numbered as ``scipy.sparse.csgraph.connected_components`` numbers those of
    the vertex graph: in the order of their lowest vertex, a vertex of no face being a component
    of its own. They are found and numbered by the compiled union-find of :mod:`meshplan._kernels`
    (:func:`~meshplan._kernels.component_labels`), three times faster than building the sparse
    graph.
    """
    from .._kernels import component_labels  # numba: loaded when first needed

    if not len(faces):
        return np.zeros(0, dtype=np.int64)
    return component_labels(np.ascontiguousarray(faces, dtype=np.int64), n_vertices)


def inward_flips(
    mesh: Mesh,
    normals: FloatArray,
    centroids: FloatArray,
    heights: FloatArray,
    stories: tuple[Story, ...],
    tolerance_m: float = 0.1,
    rotation: FloatArray | None = None,
) -> np.ndarray:
    """Boolean mask of the faces whose winding should be reversed to face into the rooms.

    Parameters
    ----------
    mesh
        The mesh (only its connectivity and face areas are used).
    normals, centroids
        ``(F, 3)`` face normals and centroids in a levelled frame (+y up).
    heights
        ``(F,)`` centroid heights, on the scale of the stories' floors and ceilings.
    stories
        Floors and ceilings found.
    rotation
        The rotation from the mesh's coordinates to the levelled frame of ``normals`` and
        ``centroids`` (default: none), which places the floor's triangles for the walls' votes.

    Notes
    -----
    Each connected component is turned by the votes of its floor faces (normals up) and ceiling
    faces (normals down). A component without any, such as a wall scanned as a patch of its
    own, is turned by its walls: a wall faces the side its story's floor is on, just in front of
    its foot (:data:`_FLOOR_PROBES_M`). Only when neither says anything does it follow the
    majority of the mesh.
    """
    from .._kernels import slab_votes  # numba: loaded when first needed

    areas = mesh.face_areas
    # the floor and ceiling faces' votes in one compiled pass (the masks of every story: 0.2 s at 3M faces)
    floors = np.array([s.floor for s in stories], dtype=np.float64)
    ceilings = np.array([s.ceiling if s.ceiling_found else np.nan for s in stories], dtype=np.float64)
    cos_horizontal = float(np.cos(np.radians(FACING_HORIZONTAL_DEG)))
    vote, horiz = np.empty(mesh.n_faces), np.empty(mesh.n_faces, dtype=bool)
    slab_votes(np.ascontiguousarray(normals[:, 1]), np.ascontiguousarray(heights), areas, floors, ceilings, float(tolerance_m), cos_horizontal, vote, horiz)
    comp = mesh.face_roots  # each piece by its lowest vertex (shared with the walls' box test)
    per = np.bincount(comp, weights=vote, minlength=mesh.n_vertices)
    undecided = per == 0
    if undecided.any():
        r = np.eye(3) if rotation is None else np.asarray(rotation, dtype=np.float64)
        walls = _wall_votes(mesh, r, normals, centroids, heights, areas, stories, horiz, tolerance_m, undecided[comp])
        per = per + np.bincount(comp, weights=walls, minlength=len(per))
    majority_out = vote.sum() < 0
    flip_comp = (per < 0) | ((per == 0) & majority_out)
    return flip_comp[comp]


#: Distances (m) in front of and behind a wall at which its story's floor is looked for: the
#: floor runs up to the wall on the room side; behind lies the wall's thickness (then, behind a
#: partition, the next room, which the nearer probe misses) or nothing.
_FLOOR_PROBES_M = (0.08, 0.2)
_FLOOR_CELL_M = 0.05
_SAMPLED_EDGE_CELLS = 32


def _wall_votes(
    mesh: Mesh,
    rotation: FloatArray,
    normals: FloatArray,
    centroids: FloatArray,
    heights: FloatArray,
    areas: FloatArray,
    stories: tuple[Story, ...],
    horiz: np.ndarray,
    tolerance_m: float,
    candidates: np.ndarray,
) -> FloatArray:
    """``(F,)`` votes of the near-vertical faces in ``candidates``: positive when their normal
    points to the side where their story's floor is. The floor is rasterized from points over
    its triangles (:data:`_FLOOR_CELL_M` apart), not from their centroids alone: the triangles of
    a coarse or decimated scan (up to 25 cm) would leave most cells empty, and the probes would
    find floor on either side by chance."""
    from .._kernels import floor_probe_votes, sample_faces  # numba: loaded when first needed

    out = np.zeros(len(normals))
    vertical = candidates & (np.abs(normals[:, 1]) < np.sin(np.radians(FACING_VERTICAL_DEG)))
    for s in stories:
        floor = horiz & (np.abs(heights - s.floor) < tolerance_m)
        mine = np.flatnonzero(vertical & (heights > s.floor) & (heights < s.ceiling))
        if not floor.any() or not len(mine):
            continue
        tri = np.ascontiguousarray(mesh.triangles[floor] @ rotation.T)
        # (faces longer than _SAMPLED_EDGE_CELLS cells are split first: the sampler puts at
        # most 64 points along an edge)
        pts = sample_faces(tri, _SAMPLED_EDGE_CELLS * _FLOOR_CELL_M, _FLOOR_CELL_M)
        cells = np.floor(pts[:, [0, 2]] / _FLOOR_CELL_M).astype(np.int64)
        lo = cells.min(axis=0)
        grid = np.zeros(tuple(cells.max(axis=0) - lo + 1), dtype=bool)
        grid[cells[:, 0] - lo[0], cells[:, 1] - lo[1]] = True

        # the probes in one compiled pass over the story's walls (numpy's gathers, float grids
        # and fancy indexing: 0.5 s at 3M faces)
        out[mine] = floor_probe_votes(normals, centroids, areas, mine, grid, lo, np.array(_FLOOR_PROBES_M), _FLOOR_CELL_M)
    return out
