"""IFC4 export (ifcopenshell, an optional extra: ``pip install meshplan[ifc]``).

The model holds an IfcProject, IfcSite and IfcBuilding; an IfcBuildingStorey per story at its
floor height; an IfcWall per physical wall (:mod:`meshplan.walls.physical`: thickness measured
where both faces were scanned, else the stated default) from floor to ceiling; an IfcSpace per room
(its floor polygon extruded to the ceiling, with its net floor area in Qto_SpaceBaseQuantities);
an IfcDoor or IfcWindow in an IfcOpeningElement that voids its wall, once per physical opening;
and the annotations as IfcSensor (sensors and thermostats) or IfcAnnotation (the others).

IFC is z-up: plan point (x, y, z) is IFC point (x, -z, y), a rotation, so the model is the plan
frame turned upright; seen from above it looks like the drawings.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import MeshplanError
from ..validation import plain_text

if TYPE_CHECKING:  # pragma: no cover
    from ..result import Result


def _require_ifcopenshell():
    try:
        import ifcopenshell  # noqa: F401
        import ifcopenshell.api  # noqa: F401
    except ImportError:
        raise MeshplanError("IFC export needs ifcopenshell, which is not installed", "pip install 'meshplan[ifc]', or leave out --ifc") from None
    return ifcopenshell


def _ifc_xy(p) -> tuple[float, float]:
    return float(p[0]), float(-p[1])


def _placement(origin_xz, height: float, direction_xz=(1.0, 0.0)) -> np.ndarray:
    """4x4 IFC placement: local x along ``direction_xz`` (plan), z up, at the plan point."""
    dx, dy = _ifc_xy(direction_xz)
    norm = np.hypot(dx, dy) or 1.0
    x = np.array([dx / norm, dy / norm, 0.0])
    z = np.array([0.0, 0.0, 1.0])
    y = np.cross(z, x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2] = x, y, z
    m[:3, 3] = [*_ifc_xy(origin_xz), height]
    return m


def ifc_bytes(result: Result) -> bytes:
    """The IFC4 model of a result, as STEP text."""
    _require_ifcopenshell()
    from ifcopenshell.api import aggregate, context, feature, geometry, project, pset, root, spatial, unit

    f = project.create_file(version="IFC4")
    proj = root.create_entity(f, ifc_class="IfcProject", name=f"meshplan: {result.input.path}")
    unit.assign_unit(
        f, length={"is_metric": True, "raw": "METERS"}, area={"is_metric": True, "raw": "SQUARE_METERS"}, volume={"is_metric": True, "raw": "CUBIC_METERS"}
    )
    model = context.add_context(f, context_type="Model")
    body = context.add_context(f, context_type="Model", context_identifier="Body", target_view="MODEL_VIEW", parent=model)
    site = root.create_entity(f, ifc_class="IfcSite", name="Site")
    building = root.create_entity(f, ifc_class="IfcBuilding", name="Building")
    aggregate.assign_object(f, products=[site], relating_object=proj)
    aggregate.assign_object(f, products=[building], relating_object=site)
    geometry.edit_object_placement(f, product=site)
    geometry.edit_object_placement(f, product=building)

    storeys = {}
    for s in result.orientation.stories:
        st = root.create_entity(f, ifc_class="IfcBuildingStorey", name=f"Story {s.index}")
        st.Elevation = float(s.floor)
        geometry.edit_object_placement(f, product=st, matrix=_placement((0.0, 0.0), float(s.floor)))
        aggregate.assign_object(f, products=[st], relating_object=building)
        storeys[s.index] = (st, s)

    # walls
    ifc_walls: list[Any] = []  # ifcopenshell entity instances
    for pw in result.physical_walls:
        st, s = storeys[pw.story]
        wall = root.create_entity(f, ifc_class="IfcWall", name=f"Wall {len(ifc_walls) + 1}")
        rep = geometry.add_wall_representation(f, context=body, length=pw.length, height=s.height, thickness=pw.thickness, offset=-pw.thickness / 2)
        geometry.assign_representation(f, product=wall, representation=rep)
        geometry.edit_object_placement(f, product=wall, matrix=_placement(pw.start, s.floor, pw.direction))
        spatial.assign_container(f, products=[wall], relating_structure=st)
        ps = pset.add_pset(f, product=wall, name="Pset_WallCommon")
        pset.edit_pset(f, pset=ps, properties={"IsExternal": False, "Reference": "meshplan"})
        ps = pset.add_pset(f, product=wall, name="meshplan")
        pset.edit_pset(f, pset=ps, properties={"faces": ",".join(str(i) for i in pw.faces), "thickness_measured": pw.paired})
        qto = pset.add_qto(f, product=wall, name="Qto_WallBaseQuantities")
        pset.edit_qto(f, qto=qto, properties={"Length": pw.length, "Width": pw.thickness, "Height": s.height})
        ifc_walls.append(wall)

    # doors and windows, once per physical opening
    from ..walls.physical import wall_of_face

    carrier = wall_of_face(result.physical_walls, len(result.walls))
    ops = result.openings
    centers = ops.center(result.walls) if len(ops) else np.zeros((0, 2))
    placed: list[tuple[int, np.ndarray]] = []
    counts = {"door": 0, "window": 0}
    for i in range(len(ops)):
        w = int(carrier[ops.wall[i]])
        if w < 0:
            continue
        if any(pw_i == w and np.linalg.norm(c - centers[i]) < 0.3 for pw_i, c in placed):
            continue  # the same opening seen from the other side of the wall
        placed.append((w, centers[i]))
        pw = result.physical_walls[w]
        kind = ops.kind[i]
        counts[kind] += 1
        width, height = float(ops.width[i]), float(ops.top[i] - ops.bottom[i])
        d = pw.direction
        u_center = float(np.dot(centers[i] - np.asarray(pw.start), d))
        origin = np.asarray(pw.start) + (u_center - width / 2) * d
        opening = root.create_entity(f, ifc_class="IfcOpeningElement", name=f"{kind} opening {counts[kind]}")
        rep = geometry.add_wall_representation(f, context=body, length=width, height=height, thickness=pw.thickness + 0.1, offset=-(pw.thickness + 0.1) / 2)
        geometry.assign_representation(f, product=opening, representation=rep)
        geometry.edit_object_placement(f, product=opening, matrix=_placement(origin, float(ops.bottom[i]), d))
        feature.add_feature(f, feature=opening, element=ifc_walls[w])
        fill = root.create_entity(f, ifc_class="IfcDoor" if kind == "door" else "IfcWindow", name=f"{kind.capitalize()} {counts[kind]}")
        fill.OverallWidth, fill.OverallHeight = width, height
        rep = geometry.add_wall_representation(f, context=body, length=width, height=height, thickness=0.05, offset=-0.025)
        geometry.assign_representation(f, product=fill, representation=rep)
        geometry.edit_object_placement(f, product=fill, matrix=_placement(origin, float(ops.bottom[i]), d))
        feature.add_filling(f, opening=opening, element=fill)
        spatial.assign_container(f, products=[fill], relating_structure=storeys[int(ops.story[i])][0])

    # rooms
    for room in result.rooms:
        st, s = storeys[room.story]
        space = root.create_entity(f, ifc_class="IfcSpace", name=room.label)
        space.LongName = room.label
        pts = [_ifc_xy(p) for p in list(room.polygon.exterior.coords)[:-1]]
        rep = geometry.add_slab_representation(f, context=body, depth=s.height, polyline=pts + [pts[0]])
        geometry.assign_representation(f, product=space, representation=rep)
        geometry.edit_object_placement(f, product=space, matrix=_placement((0.0, 0.0), float(s.floor)))
        aggregate.assign_object(f, products=[space], relating_object=st)
        qto = pset.add_qto(f, product=space, name="Qto_SpaceBaseQuantities")
        pset.edit_qto(f, qto=qto, properties={"NetFloorArea": room.area, "GrossFloorArea": room.area, "Height": s.height})

    # annotations
    ann = result.annotations
    for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds)):
        # the user's text as it is, without the characters STEP cannot encode (lone surrogates)
        # or IFC viewers choke on (NUL); never cut: labels are at most MAX_LABEL_CHARS (200),
        # within IfcLabel's 255 characters
        label = plain_text(label)
        story = int(result.annotation_story[i]) if len(result.annotation_story) else 0
        if kind in ("sensor", "thermostat"):
            el = root.create_entity(f, ifc_class="IfcSensor", name=label, predefined_type="TEMPERATURESENSOR" if kind == "thermostat" else "NOTDEFINED")
        else:
            el = root.create_entity(f, ifc_class="IfcAnnotation", name=label)
        el.ObjectType = kind
        p = ann.positions[i]
        d = ann.directions[i]
        direction = (d[0], d[2]) if np.all(np.isfinite(d)) and np.hypot(d[0], d[2]) > 1e-6 else (1.0, 0.0)
        geometry.edit_object_placement(f, product=el, matrix=_placement((p[0], p[2]), float(p[1]), direction))
        spatial.assign_container(f, products=[el], relating_structure=storeys[story][0])
    _make_deterministic(f)
    return f.to_string().encode("utf-8")


def _make_deterministic(f) -> None:
    """Same result, same file: GlobalIds from a name-based UUID of each entity's position in the
    file, and no timestamp in the header."""
    import uuid

    import ifcopenshell.guid

    space = uuid.UUID("6d657368-706c-616e-2069-6663206d6f64")  # "meshplan ifc mod"
    for k, ent in enumerate(f.by_type("IfcRoot")):
        ent.GlobalId = ifcopenshell.guid.compress(uuid.uuid5(space, f"{k}:{ent.is_a()}").hex)
    for ent in f.by_type("IfcOwnerHistory"):
        ent.CreationDate = 0
        if hasattr(ent, "LastModifiedDate"):
            ent.LastModifiedDate = None
    f.header.file_name.time_stamp = "2000-01-01T00:00:00"
    # ifcopenshell gathers related elements in a set: order them by entity id
    for rel in f.by_type("IfcRelContainedInSpatialStructure"):
        rel.RelatedElements = sorted(rel.RelatedElements, key=lambda e: e.id())
    for rel in f.by_type("IfcRelAggregates"):
        rel.RelatedObjects = sorted(rel.RelatedObjects, key=lambda e: e.id())
    for ua in f.by_type("IfcUnitAssignment"):
        ua.Units = sorted(ua.Units, key=lambda e: e.id())
