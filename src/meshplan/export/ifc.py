"""IFC4 export (ifcopenshell, an optional extra: ``pip install meshplan[ifc]``).

The model holds an IfcProject, IfcSite and IfcBuilding; an IfcBuildingStorey per story at its
floor height; an IfcWall per physical wall (:mod:`meshplan.walls.physical`: thickness measured
where both faces were scanned, else the stated default) from floor to ceiling; an IfcSpace per room
(its floor polygon extruded to the ceiling, with its net floor area in Qto_SpaceBaseQuantities);
an IfcDoor or IfcWindow in an IfcOpeningElement that voids its wall, once per physical opening
(referenced by the spaces it connects); and the annotations, each contained in the IfcSpace it
belongs to (the room its probe points into), placed at its point with its local x along its
probe: a thermostat as an IfcUnitaryControlElement (THERMOSTAT) aggregating the IfcSensor
(TEMPERATURESENSOR) it implies, a sensor as an IfcSensor typed by what its label says it
measures (:func:`sensor_type`), a door or window mark as the detected IfcDoor or IfcWindow it
marks (tagged with its label and referenced by its space), or as its own element where none was
detected, anything else as an IfcAnnotation. Every user mark keeps its label, position and
probe in a ``meshplan_annotation`` property set.

IFC is z-up: plan point (x, y, z) is IFC point (x, -z, y), a rotation, so the model is the plan
frame turned upright; seen from above it looks like the drawings.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import MeshplanError
from ..plan.symbols import door_frame
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
    room_no = [r.number or r.label for r in result.rooms]
    ifc_walls: list[Any] = []  # ifcopenshell entity instances
    for pw in result.physical_walls:
        st, s = storeys[pw.story]
        wall = root.create_entity(f, ifc_class="IfcWall", name=f"Wall {len(ifc_walls) + 1}", predefined_type="STANDARD")
        rep = geometry.add_wall_representation(f, context=body, length=pw.length, height=s.height, thickness=pw.thickness, offset=-pw.thickness / 2)
        geometry.assign_representation(f, product=wall, representation=rep)
        geometry.edit_object_placement(f, product=wall, matrix=_placement(pw.start, s.floor, pw.direction))
        spatial.assign_container(f, products=[wall], relating_structure=st)
        ps = pset.add_pset(f, product=wall, name="Pset_WallCommon")
        pset.edit_pset(f, pset=ps, properties={"IsExternal": bool(pw.exterior), "Reference": "meshplan"})
        ps = pset.add_pset(f, product=wall, name="meshplan")
        props: dict[str, Any] = {"faces": ",".join(str(i) for i in pw.faces), "thickness_measured": pw.paired or pw.revealed}
        if pw.confidence:
            props.update(confidence=pw.confidence, confidence_reason=pw.confidence_reason)
        for side, rooms in zip(("rooms_front", "rooms_back"), pw.rooms):
            if rooms:
                props[side] = ",".join(room_no[k] for k in rooms)
        pset.edit_pset(f, pset=ps, properties=props)
        qto = pset.add_qto(f, product=wall, name="Qto_WallBaseQuantities")
        pset.edit_qto(f, qto=qto, properties={"Length": pw.length, "Width": pw.thickness, "Height": s.height})
        ifc_walls.append(wall)

    # rooms
    spaces: list[Any] = []
    for room in result.rooms:
        st, s = storeys[room.story]
        space = root.create_entity(f, ifc_class="IfcSpace", name=room.number or room.label, predefined_type="INTERNAL")
        space.LongName = room.label
        space.ObjectType = room.type
        pts = [_ifc_xy(p) for p in list(room.polygon.exterior.coords)[:-1]]
        rep = geometry.add_slab_representation(f, context=body, depth=s.height, polyline=pts + [pts[0]])
        geometry.assign_representation(f, product=space, representation=rep)
        geometry.edit_object_placement(f, product=space, matrix=_placement((0.0, 0.0), float(s.floor)))
        aggregate.assign_object(f, products=[space], relating_object=st)
        qto = pset.add_qto(f, product=space, name="Qto_SpaceBaseQuantities")
        pset.edit_qto(f, qto=qto, properties={"NetFloorArea": room.area, "GrossFloorArea": room.area, "Height": s.height})
        if room.confidence:
            ps = pset.add_pset(f, product=space, name="meshplan")
            props = {"number": room.number, "type": room.type, "closed_by": room.closed_by}
            props.update(confidence=room.confidence, confidence_reason=room.confidence_reason)
            pset.edit_pset(f, pset=ps, properties=props)
        spaces.append(space)

    # doors and windows, once per physical opening
    from ..walls.physical import wall_of_face

    carrier = wall_of_face(result.physical_walls, len(result.walls))
    ops = result.openings
    elements = result.opening_elements
    centers = ops.center(result.walls) if len(ops) else np.zeros((0, 2))
    placed: list[tuple[int, np.ndarray]] = []
    fills: dict[int, Any] = {}  # opening row -> its IfcDoor or IfcWindow
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
        el = elements[i] if i < len(elements) else None
        width, height = float(ops.width[i]), float(ops.top[i] - ops.bottom[i])
        d = np.asarray(pw.direction, dtype=np.float64)
        u_center = float(np.dot(centers[i] - np.asarray(pw.start), d))
        origin = np.asarray(pw.start) + (u_center - width / 2) * d
        operation, fill_origin, fill_d = "NOTDEFINED", origin, d
        if kind == "door" and el is not None and el.swing is not None:
            jambs = (float(ops.u_min[i]), float(ops.u_max[i]))
            operation, fill_origin, fill_d = _swung_door(el.swing, result.walls, int(ops.wall[i]), jambs, pw, u_center, width)
        opening = root.create_entity(f, ifc_class="IfcOpeningElement", name=f"{kind} opening {counts[kind]}", predefined_type="OPENING")
        rep = geometry.add_wall_representation(f, context=body, length=width, height=height, thickness=pw.thickness + 0.1, offset=-(pw.thickness + 0.1) / 2)
        geometry.assign_representation(f, product=opening, representation=rep)
        geometry.edit_object_placement(f, product=opening, matrix=_placement(origin, float(ops.bottom[i]), d))
        feature.add_feature(f, feature=opening, element=ifc_walls[w])
        fill = root.create_entity(
            f, ifc_class="IfcDoor" if kind == "door" else "IfcWindow", name=f"{kind.capitalize()} {counts[kind]}", predefined_type=kind.upper()
        )
        fill.OverallWidth, fill.OverallHeight = width, height
        if kind == "door":
            fill.OperationType = operation
        rep = geometry.add_wall_representation(f, context=body, length=width, height=height, thickness=0.05, offset=-0.025)
        geometry.assign_representation(f, product=fill, representation=rep)
        geometry.edit_object_placement(f, product=fill, matrix=_placement(fill_origin, float(ops.bottom[i]), fill_d))
        feature.add_filling(f, opening=opening, element=fill)
        spatial.assign_container(f, products=[fill], relating_structure=storeys[int(ops.story[i])][0])
        if el is not None:
            ps = pset.add_pset(f, product=fill, name="meshplan")
            props = {"clear_width": el.clear_width, "height": el.height, "confidence": el.confidence, "confidence_reason": el.confidence_reason}
            props["connects"] = ",".join(_room_ref(x, room_no) for x in el.connects)
            if el.sill is not None:
                props["sill"] = el.sill
            if el.opens_to is not None:
                props["opens_to"] = _room_ref(el.opens_to, room_no)
            pset.edit_pset(f, pset=ps, properties=props)
            # the spaces on either side see the door or window (referenced, not contained)
            for x in sorted({x for x in el.connects if isinstance(x, int)}):
                spatial.reference_structure(f, products=[fill], relating_structure=spaces[x])
        fills[i] = fill

    # annotations, in the space that holds them (or their storey), along their probe
    ann = result.annotations
    for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds)):
        # the user's text as it is, without the characters STEP cannot encode (lone surrogates)
        # or IFC viewers choke on (NUL); never cut: labels are at most MAX_LABEL_CHARS (200),
        # within IfcLabel's 255 characters
        label = plain_text(label)
        story = int(result.annotation_story[i]) if len(result.annotation_story) else 0
        p = ann.positions[i]
        d = ann.directions[i]
        has_probe = bool(np.all(np.isfinite(d)) and np.linalg.norm(d) > 1e-6)
        direction = (d[0], d[2]) if has_probe and np.hypot(d[0], d[2]) > 1e-6 else (1.0, 0.0)
        matrix = _placement((p[0], p[2]), float(p[1]), direction)
        home = annotation_room(result, i)
        where = spaces[home] if home is not None else storeys[story][0]
        if kind in ("door", "window"):
            target = _marked_opening(result, i, fills)
            if target is not None:  # the user's mark names the element that was found
                marked = fills[target]
                marked.Tag = label
                _annotation_pset(f, pset, marked, label, kind, p, d if has_probe else None, detected=True)
                if home is not None:
                    spatial.reference_structure(f, products=[marked], relating_structure=spaces[home])
                continue
            item = root.create_entity(f, ifc_class="IfcDoor" if kind == "door" else "IfcWindow", name=label, predefined_type=kind.upper())
            item.Tag = label
        elif kind == "thermostat":
            item = root.create_entity(f, ifc_class="IfcUnitaryControlElement", name=label, predefined_type="THERMOSTAT")
        elif kind == "sensor":
            item = root.create_entity(f, ifc_class="IfcSensor", name=label, predefined_type=sensor_type(label))
        else:
            item = root.create_entity(f, ifc_class="IfcAnnotation", name=label)
        item.ObjectType = kind
        geometry.edit_object_placement(f, product=item, matrix=matrix)
        spatial.assign_container(f, products=[item], relating_structure=where)
        _annotation_pset(f, pset, item, label, kind, p, d if has_probe else None, detected=kind not in ("door", "window"))
        if kind == "thermostat":
            # a thermostat measures the temperature where it hangs: its sensor is a part of it
            sensor = root.create_entity(f, ifc_class="IfcSensor", name=f"{label} sensor", predefined_type="TEMPERATURESENSOR")
            sensor.ObjectType = "thermostat sensor"
            geometry.edit_object_placement(f, product=sensor, matrix=matrix)
            aggregate.assign_object(f, products=[sensor], relating_object=item)
    _add_stairs(f, result, storeys, body)
    _make_deterministic(f)
    return f.to_string().encode("utf-8")


#: A door or window annotation marks the detected opening of its kind whose span, on its wall,
#: passes within this distance (m) of the mark: users click the leaf or the frame, up to a
#: wall's thickness and a hand's width off the opening's line.
MARK_REACH_M = 0.4

#: An annotation belongs to the room its probe points into, looked for this far (m) along it
#: (sensors hang on walls, which room polygons stop at), else to the room nearest to it within
#: :data:`ROOM_REACH_M`.
PROBE_STEP_M = 0.3
ROOM_REACH_M = 0.5

#: Words in a sensor's label that say what it measures -> IfcSensorTypeEnum (checked in order,
#: as whole words or prefixes of them, case-insensitively).
SENSOR_WORDS = (
    (("co2", "carbon dioxide"), "CO2SENSOR"),
    (("co", "carbon monoxide"), "COSENSOR"),
    (("temp", "temperature", "thermo"), "TEMPERATURESENSOR"),
    (("humid", "rh", "moisture"), "HUMIDITYSENSOR"),
    (("light", "lux", "illum"), "LIGHTSENSOR"),
    (("motion", "occupancy", "presence", "pir", "movement"), "MOVEMENTSENSOR"),
    (("smoke",), "SMOKESENSOR"),
    (("sound", "noise", "acoustic"), "SOUNDSENSOR"),
    (("pressure",), "PRESSURESENSOR"),
    (("contact", "reed"), "CONTACTSENSOR"),
    (("voc", "gas"), "GASSENSOR"),
    (("flow",), "FLOWSENSOR"),
)


def sensor_type(label: str) -> str:
    """The IfcSensorTypeEnum a sensor's label names (:data:`SENSOR_WORDS`), else NOTDEFINED."""
    import re

    words = re.findall(r"[a-z0-9]+", label.lower())
    text = " ".join(words)
    for keys, kind in SENSOR_WORDS:
        for key in keys:
            if " " in key and key in text:
                return kind
            if any(w == key or (len(key) >= 4 and w.startswith(key)) for w in words):
                return kind
    return "NOTDEFINED"


def annotation_room(result: Result, i: int) -> int | None:
    """Index of the room annotation ``i`` belongs to (:data:`PROBE_STEP_M`), or ``None``."""
    from shapely.geometry import Point

    story = int(result.annotation_story[i]) if len(result.annotation_story) else 0
    p = result.annotations.positions[i]
    d = result.annotations.directions[i]
    here = np.array([p[0], p[2]], dtype=np.float64)
    probe = np.array([d[0], d[2]], dtype=np.float64) if np.all(np.isfinite(d)) else np.zeros(2)
    spots = [here + PROBE_STEP_M * probe / np.linalg.norm(probe)] if np.linalg.norm(probe) > 1e-6 else []
    mine = [k for k, r in enumerate(result.rooms) if r.story == story]
    for spot in [*spots, here]:
        for k in mine:
            if result.rooms[k].polygon.contains(Point(spot)):
                return k
    if not mine:
        return None
    k = min(mine, key=lambda j: result.rooms[j].polygon.distance(Point(here)))
    return k if result.rooms[k].polygon.distance(Point(here)) <= ROOM_REACH_M else None


def _marked_opening(result: Result, i: int, fills: dict[int, Any]) -> int | None:
    """The opening row (with an IFC element in ``fills``) that door or window annotation ``i``
    marks (:data:`MARK_REACH_M`), or ``None``."""
    ops, walls = result.openings, result.walls
    kind = result.annotations.kinds[i]
    story = int(result.annotation_story[i]) if len(result.annotation_story) else 0
    p = result.annotations.positions[i]
    q = np.array([p[0], p[2]])
    best, best_d = None, MARK_REACH_M
    for k in fills:
        if ops.kind[k] != kind or int(ops.story[k]) != story:
            continue
        w = int(ops.wall[k])
        t, n, off = walls.tangent[w], walls.normal[w], walls.offset[w]
        u = float(np.clip(q @ t, ops.u_min[k], ops.u_max[k]))
        dist = float(np.linalg.norm(q - (u * t + off * n)))
        if dist <= best_d:
            best, best_d = k, dist
    return best


def _room_ref(x: Any, numbers: list[str]) -> str:
    return numbers[x] if isinstance(x, int) else "outside" if x == "outside" else "unknown"


def _swung_door(swing: Any, walls: Any, face: int, jambs: tuple[float, float], pw: Any, u_center: float, width: float) -> tuple[str, np.ndarray, np.ndarray]:
    """An IfcDoor whose leaf the scan showed (found in flat wall ``face`` between ``jambs``,
    along it): its OperationType and placement (plan origin and local x direction). IFC opens a
    door towards its placement's +y and names the hand looking that way ("hinges on the left
    side as viewed in the direction of the positive y-axis"): local x runs along the wall so that +y (z x x, with z up) points into the room the leaf
    opens into (:func:`meshplan.plan.symbols.door_frame`), from the jamb at local x = 0, and
    the door is SINGLE_SWING_LEFT when its hinge is at that jamb. Before, every door was placed
    along its physical wall's direction and named by the hand seen from the room it opens into,
    so that half of them opened into the wrong room and the others had the mirrored hand."""
    d = np.asarray(pw.direction, dtype=np.float64)
    jamb, _, out = door_frame(swing, walls, face, *jambs, pw.thickness)
    # plan +y of a placement whose local x is e: (e_z, -e_x) (IFC y = -plan z); +y = out
    e = np.array([-out[1], out[0]])
    sign = 1.0 if float(e @ d) >= 0.0 else -1.0
    start_u = u_center - sign * width / 2  # along d, where local x = 0
    hinge_u = float((jamb - np.asarray(pw.start)) @ d)
    at_start = abs(hinge_u - start_u) <= abs(hinge_u - (u_center + sign * width / 2))
    origin = np.asarray(pw.start) + start_u * d
    return ("SINGLE_SWING_LEFT" if at_start else "SINGLE_SWING_RIGHT"), origin, sign * d


def _annotation_pset(f, pset, el, label: str, kind: str, p, d, detected: bool) -> None:
    """The user's mark on ``el``: label, kind, position and probe (IFC coordinates: x, -z, y)."""
    ps = pset.add_pset(f, product=el, name="meshplan_annotation")
    props: dict[str, Any] = {"label": label, "kind": kind, "x": float(p[0]), "y": float(-p[2]), "z": float(p[1]), "detected": detected}
    if d is not None:
        props.update(probe_x=float(d[0]), probe_y=float(-d[2]), probe_z=float(d[1]))
    pset.edit_pset(f, pset=ps, properties=props)


#: IfcStairTypeEnum of each stair shape (:class:`meshplan.plan.stairs.StairElement`).
STAIR_TYPES = {"straight": "STRAIGHT_RUN_STAIR", "L": "QUARTER_TURN_STAIR", "U": "HALF_TURN_STAIR", "winding": "NOTDEFINED"}


def _add_stairs(f, result: Result, storeys: dict, body) -> None:
    """An IfcStair per stair in the storey it starts on, with its footprint (a FootPrint
    Curve2D representation in a Plan context), aggregating an IfcStairFlight per flight and an
    IfcSlab (LANDING) per landing, each tread a block one rise deep below its height;
    Pset_StairCommon and a ``meshplan`` property set with what it connects."""
    from ifcopenshell.api import aggregate, geometry, pset, root, spatial

    def block(tread, depth: float):
        pts = [f.createIfcCartesianPoint(_ifc_xy(p)) for p in list(tread.polygon.exterior.coords)]
        profile = f.createIfcArbitraryClosedProfileDef("AREA", None, f.createIfcPolyline(pts))
        at = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, float(tread.height) - depth)), None, None)
        return f.createIfcExtrudedAreaSolid(profile, at, f.createIfcDirection((0.0, 0.0, 1.0)), float(depth))

    def shape(product, treads, depth: float, parent) -> None:
        rep = f.createIfcShapeRepresentation(body, "Body", "SweptSolid", [block(t, depth) for t in treads])
        geometry.assign_representation(f, product=product, representation=rep)
        # at the stair's placement, made here: the API's placement edits are not repeatable
        at = f.createIfcAxis2Placement3D(f.createIfcCartesianPoint((0.0, 0.0, 0.0)), None, None)
        product.ObjectPlacement = f.createIfcLocalPlacement(parent.ObjectPlacement, at)

    room_no = [r.number or r.label for r in result.rooms]
    footprint_context = None
    if result.stairs:
        from ifcopenshell.api import context

        plan = context.add_context(f, context_type="Plan")
        footprint_context = context.add_context(f, context_type="Plan", context_identifier="FootPrint", target_view="PLAN_VIEW", parent=plan)
    for k, s in enumerate(result.stairs):
        st, _ = storeys[s.story]
        stair = root.create_entity(f, ifc_class="IfcStair", name=f"Stair {k + 1}", predefined_type=STAIR_TYPES.get(s.shape, "NOTDEFINED"))
        geometry.edit_object_placement(f, product=stair, matrix=_placement((0.0, 0.0), 0.0))
        if footprint_context is not None and not s.footprint.is_empty:
            # its outline in plan (the FootPrint a plan view draws), at the height it starts from
            ring = [f.createIfcCartesianPoint(_ifc_xy(p)) for p in list(_outer(s.footprint).exterior.coords)]
            rep = f.createIfcShapeRepresentation(footprint_context, "FootPrint", "Curve2D", [f.createIfcPolyline(ring)])
            geometry.assign_representation(f, product=stair, representation=rep)
        spatial.assign_container(f, products=[stair], relating_structure=st)
        parts = []
        for i, fl in enumerate(s.flights):
            flight = root.create_entity(f, ifc_class="IfcStairFlight", name=f"Stair {k + 1} flight {i + 1}", predefined_type="STRAIGHT")
            flight.NumberOfRisers, flight.NumberOfTreads = int(fl.risers), len(fl.treads)
            flight.RiserHeight, flight.TreadLength = float(s.rise), float(fl.going)
            shape(flight, [s.treads[j] for j in fl.treads], s.rise, stair)
            parts.append(flight)
        for i, t in enumerate(x for x in s.treads if x.landing):
            landing = root.create_entity(f, ifc_class="IfcSlab", name=f"Stair {k + 1} landing {i + 1}", predefined_type="LANDING")
            shape(landing, [t], s.rise, stair)
            parts.append(landing)
        # one part at a time: the API walks the products it is given as a set, and re-makes
        # their placements in that order (the same model got different entity numbers, run to run)
        for part in parts:
            aggregate.assign_object(f, products=[part], relating_object=stair)
        ps = pset.add_pset(f, product=stair, name="Pset_StairCommon")
        pset.edit_pset(
            f, pset=ps,
            properties={
                "NumberOfRiser": int(s.risers), "NumberOfTreads": max(int(s.risers) - 1, 0), "RiserHeight": float(s.rise),
                "TreadLength": float(s.going), "Reference": "meshplan",
            },
        )
        ps = pset.add_pset(f, product=stair, name="meshplan")
        props: dict[str, Any] = {"story": int(s.story), "shape": s.shape, "treads_found": len(s.treads)}
        props.update(confidence=s.confidence, confidence_reason=s.confidence_reason)
        if s.to_story is not None:
            props["to_story"] = int(s.to_story)
        if s.room is not None:
            props["room"] = room_no[s.room]
        if s.room_above is not None:
            props["room_above"] = room_no[s.room_above]
        if s.void is not None:
            props["void_area"] = float(s.void.area)
        pset.edit_pset(f, pset=ps, properties=props)


def _outer(poly):
    """The largest polygon of a (multi)polygon, without holes: a footprint's outline."""
    from shapely.geometry import Polygon

    parts = list(getattr(poly, "geoms", [poly]))
    return Polygon(max(parts, key=lambda g: g.area).exterior)


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
    for rel in f.by_type("IfcRelReferencedInSpatialStructure"):
        rel.RelatedElements = sorted(rel.RelatedElements, key=lambda e: e.id())
    for rel in f.by_type("IfcRelAggregates"):
        rel.RelatedObjects = sorted(rel.RelatedObjects, key=lambda e: e.id())
    for ua in f.by_type("IfcUnitAssignment"):
        ua.Units = sorted(ua.Units, key=lambda e: e.id())
