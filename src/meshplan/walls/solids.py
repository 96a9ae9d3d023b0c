"""Objects modelled as boxes: the furniture of parametric models is not wall evidence.

Parametric room models (Apple RoomPlan exports converted to meshes, Meta Quest scene models,
room-mode captures) draw every element as a box of 12 triangles: walls as boxes as thin as a
sheet (RoomPlan's are 0.1 mm) or as single quads, and every object (bookcases, storage, tables,
beds, sofas) as a solid box standing on the floor. A box thicker than any wall in both plan
directions is an object, not a wall: its sides are vertical surfaces, but they bound a piece of
furniture, not a space. Raw scans never hold such a closed 12-triangle cuboid of their own.

The sides of a box are not told apart by their normals: a box standing on the floor is turned
inside out by the winding repair (its bottom face votes like a floor, :mod:`meshplan.orient.facing`),
so its top faces down and its sides face into the box, and the test of a furniture top attached
behind a front (:func:`meshplan.walls.evidence.top_attached`) looks on the wrong side of it.
"""

from __future__ import annotations

import numpy as np

from ..geometry import Mesh

#: Triangles and distinct corners of a box modelled as a cuboid (6 rectangles, 2 triangles each).
BOX_FACES = 12
BOX_VERTICES = 8

#: The faces of a cuboid are parallel or perpendicular to each other to this angle (degrees):
#: parametric models write exact boxes (float32 rounding only), a patch of a raw scan does not.
BOX_SQUARE_DEG = 1.0

#: One axis of a standing box is vertical to within this angle (degrees): the tilt left by
#: levelling (under a degree on the real scans) plus that of a model written in its own frame.
BOX_UPRIGHT_DEG = 5.0


def object_boxes(mesh: Mesh, max_wall_thickness_m: float) -> np.ndarray:
    """``(F,)`` whether each face belongs to an upright box thicker than ``max_wall_thickness_m``
    in both plan directions (an object of a parametric model, see the module docstring).

    Parameters
    ----------
    mesh
        The mesh in the plan frame (+y up).
    max_wall_thickness_m
        The thickest wall (m, ``WallParams.max_wall_thickness_m``): a box thinner than this in
        one plan direction may be a wall (RoomPlan's walls are boxes 0.1 mm thick).
    """
    out = np.zeros(mesh.n_faces, dtype=bool)
    if mesh.n_faces < BOX_FACES:
        return out
    comp = mesh.face_roots  # computed once per mesh (the plan mesh has the orientation's)
    counts = np.bincount(comp)  # pieces are labelled by a vertex: one bincount, no sort of all faces
    in_twelve = np.flatnonzero(counts[comp] == BOX_FACES)
    if not len(in_twelve):
        return out
    order = in_twelve[np.argsort(comp[in_twelve], kind="stable")]
    starts = np.arange(0, len(order), BOX_FACES)
    cos_square = np.cos(np.radians(BOX_SQUARE_DEG))
    sin_square = np.sin(np.radians(BOX_SQUARE_DEG))
    cos_up = np.cos(np.radians(BOX_UPRIGHT_DEG))
    normals = mesh.face_normals
    for s in starts:
        faces = order[s : s + BOX_FACES]
        corners = np.unique(mesh.faces[faces])
        if len(corners) != BOX_VERTICES:
            continue
        n = normals[faces]
        # the box's three axes: the vertical one and two horizontal ones, every face along one
        up = np.abs(n[:, 1]) >= cos_up
        side = ~up
        if not up.any() or not side.any():
            continue
        a = n[side][0]
        along_a = np.abs(n @ a) >= cos_square
        across = side & ~along_a
        if not across.any():
            continue
        b = n[across][0]
        along_b = np.abs(n @ b) >= cos_square
        if abs(a @ b) > sin_square or not np.all(up | along_a | along_b):
            continue
        v = mesh.vertices[corners]
        ha, hb = np.array([a[0], a[2]]), np.array([b[0], b[2]])
        ha, hb = ha / max(np.linalg.norm(ha), 1e-12), hb / max(np.linalg.norm(hb), 1e-12)
        width = np.ptp(v[:, [0, 2]] @ ha)
        depth = np.ptp(v[:, [0, 2]] @ hb)
        if min(width, depth) > max_wall_thickness_m:
            out[faces] = True
    return out
