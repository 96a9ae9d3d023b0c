"""Scoring a plan (plan.json) against the hand-digitized truth of a real scan.

The truth files (one ``<scan stem>.truth.json`` per scan, kept outside the package) are a
careful reading of each mesh: wall face lines, rooms, doors and windows in a *truth frame*
(metres, +y up, plan coordinates ``(x, z)``) that is the scan's input frame rotated and shifted.
They are told apart from the synthetic truth of ``meshplan synth`` by their ``truth_to_input``
matrix (see :func:`is_real_truth`).

No alignment is estimated: the truth is carried into the plan frame by

    M = plan.transform @ S @ truth_to_input

(``S`` scales input units to metres, from ``plan.input.units``), so every error meshplan made,
orientation included, shows in the scores. Per truth story, matched to the plan story whose
floor is nearest (within :data:`STORY_MATCH_M`):

* **walls**: a predicted wall face's length counts as matched where it lies within
  :data:`WALL_DISTANCE_M` of, and within :data:`WALL_ANGLE_DEG` of the direction of, a truth
  wall of the same story (sure or unsure). The matched portion is measured by sampling the
  segment every :data:`WALL_SAMPLE_M`, not all-or-nothing. Precision = matched / predicted
  length; recall = the length of *sure* truth walls covered by predictions (the same test the
  other way round) / their length; F1. *Furniture length* = predicted length matching no truth
  wall (cabinets, shelves, desks taken for walls; unsure truth walls count as walls here).
* **rooms**: one-to-one, maximising the total IoU (Hungarian assignment), pairs kept at IoU >=
  :data:`ROOM_IOU_MIN`; a truth room with ``polygon_alt`` uses the better of its two outlines.
  Precision, recall, mean IoU and mean area error ``|pred - truth| / truth`` over the pairs.
* **doors, windows**: one-to-one, same story, centres within :data:`OPENING_DISTANCE_M`, the
  nearest pairs first; recall counts *sure* truth openings only.
* **stories**: floor and ceiling errors (plan minus truth, signed) at the centre of the truth
  story; the ceiling is skipped where the truth has none (``ceiling: null``).

Plan stories without a truth story are not scored (listed in ``unscored_plan_stories``).

Why one long module: one scorer per element kind (stories, walls, rooms, openings) plus the
frame mapping and the text report, all following the truth README's rules, which read best side
by side.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .errors import InputError
from .units import UNITS_M as _UNITS_M

#: ``format`` of the report made by :func:`evaluate_real`.
REAL_REPORT_FORMAT = "meshplan-real-evaluation/1"

#: Largest distance (m) from a truth wall line at which a predicted wall face still matches it
#: (the truth README's 15 cm: a wall's thickness of plaster and scan noise, not a furniture front).
WALL_DISTANCE_M = 0.15
#: Largest angle (degrees) between a predicted wall and a truth wall that still match (10 degrees).
WALL_ANGLE_DEG = 10.0
#: Spacing (m) of the samples that measure the matched part of a wall. The samples are the
#: midpoints of equal pieces, so a wall that matches wholly or not at all is measured exactly
#: and a partial match to within this spacing.
WALL_SAMPLE_M = 0.005
#: Smallest intersection over union (0.5) of a predicted room and the truth room paired with it.
ROOM_IOU_MIN = 0.5
#: Largest distance (m) between the centres of a predicted and a truth opening that match (40 cm).
OPENING_DISTANCE_M = 0.40
#: Largest difference (m) between a truth story's floor and the plan story it is scored against.
STORY_MATCH_M = 0.5
#: Slack (m) on distance comparisons, so that a fake plan made from the truth itself, turned and
#: shifted, matches despite rounding in the 4x4 products.
_EPS_M = 1e-9

#: Metres per unit of ``plan.input.units`` (as meshplan.io.UNITS_M, repeated here so that
#: scoring does not import the mesh readers).

_HINT = "give a plan.json written by meshplan run and a <scan>.truth.json"


#: The truth's levelling (its README): faces within this angle (degrees) of up are horizontal,
#: those within this distance (m) of the lowest strong level are the floor, and the plane fit
#: is repeated this many times; the height histogram has bins of this size (m), and a level
#: is strong above this share of its largest bin.
LEVEL_CONE_DEG, LEVEL_BAND_M, LEVEL_ROUNDS, LEVEL_BIN_M, LEVEL_STRONG = 10.0, 0.1, 3, 0.02, 0.2


def truth_levelling(centroids: np.ndarray, normals: np.ndarray, areas: np.ndarray, up: Any) -> np.ndarray:
    """Up as the truth files level a scan (their README: "up starts as the file's +y and is
    refined by an area-weighted plane fit to the floor faces (normal within 10 degrees of up,
    within 10 cm of the lowest strong peak of the height histogram of horizontal faces), three
    iterations"), from ``up`` (input coordinates), for the faces' ``centroids``, ``normals``
    and ``areas``.

    The reference up of a scan that has no truth file, measured the way the truth measures it:
    where a scan's floor lies off its device's up (a Tango room's by 1.3-1.7 degrees), the
    truth's up follows the floor, and so does meshplan's.
    """
    c, n, a = (np.asarray(v, dtype=np.float64) for v in (centroids, normals, areas))
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    for _ in range(LEVEL_ROUNDS):
        h = c @ up
        horizontal = np.abs(n @ up) > np.cos(np.radians(LEVEL_CONE_DEG))
        if not horizontal.any():
            break
        bins = np.arange(h[horizontal].min(), h[horizontal].max() + 2 * LEVEL_BIN_M, LEVEL_BIN_M)
        hist, edges = np.histogram(h[horizontal], bins=bins, weights=a[horizontal])
        lowest = edges[np.flatnonzero(hist > LEVEL_STRONG * hist.max())[0]]
        floor = horizontal & (np.abs(h - lowest) < LEVEL_BAND_M)
        p, w = c[floor], a[floor]
        d = p - (w[:, None] * p).sum(axis=0) / w.sum()
        normal = np.linalg.eigh((d * w[:, None]).T @ d)[1][:, 0]
        up = normal * np.sign(normal @ up)
    return up


def is_real_truth(truth: Any) -> bool:
    """Whether ``truth`` is a real-scan truth file (it has ``truth_to_input``)."""
    return isinstance(truth, dict) and "truth_to_input" in truth


def truth_to_plan_matrix(plan: dict, truth: dict) -> np.ndarray:
    """The 4x4 matrix ``plan.transform @ S @ truth_to_input`` (truth frame to plan frame).

    Raises
    ------
    InputError
        When either matrix is missing or not 4x4, or the plan's units are unknown.
    """
    try:
        transform = np.asarray(plan["transform"], dtype=np.float64)
        t2i = np.asarray(truth["truth_to_input"], dtype=np.float64)
    except (KeyError, ValueError, TypeError):
        raise InputError("plan has no valid 'transform' or truth no valid 'truth_to_input'", _HINT) from None
    if transform.shape != (4, 4) or t2i.shape != (4, 4):
        raise InputError("'transform' and 'truth_to_input' must be 4x4 matrices", _HINT)
    units = (plan.get("input") or {}).get("units", "m")
    if units not in _UNITS_M:
        raise InputError(f"plan input units {units!r} unknown", f"use one of {', '.join(_UNITS_M)}")
    scale = np.diag([_UNITS_M[units]] * 3 + [1.0])
    return transform @ scale @ t2i


def map_truth_xz(m: np.ndarray, xz: Any, y: float | np.ndarray) -> np.ndarray:
    """Truth-frame points ``(x, z)`` at height(s) ``y``, in plan coordinates ``(x, z)``.

    Parameters
    ----------
    m
        The truth-to-plan matrix of :func:`truth_to_plan_matrix`.
    xz
        (n, 2) truth coordinates.
    y
        Truth height(s) of the points (they matter where the plan is not level with the truth).
    """
    xz = np.asarray(xz, dtype=np.float64).reshape(-1, 2)
    pts = np.c_[xz[:, 0], np.broadcast_to(y, len(xz)), xz[:, 1], np.ones(len(xz))] @ m.T
    return pts[:, [0, 2]]


def _height(m: np.ndarray, xz: np.ndarray, y: float) -> float:
    """Plan height of the truth point ``(x, y, z)``."""
    return float((m @ np.array([xz[0], y, xz[1], 1.0]))[1])


# ----------------------------------------------------------------------------------- walls


def _segment_distances(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (n, m) from ``points`` (n, 2) to the segments ``a[j] - b[j]`` (m, 2)."""
    d = b - a
    dd = np.maximum(np.einsum("ij,ij->i", d, d), 1e-24)
    rel = points[:, None, :] - a[None, :, :]
    t = np.clip(np.einsum("nmk,mk->nm", rel, d) / dd, 0.0, 1.0)
    return np.linalg.norm(rel - t[..., None] * d[None], axis=2)


def covered_lengths(segments: np.ndarray, others: np.ndarray, distance_m: float = WALL_DISTANCE_M, angle_deg: float = WALL_ANGLE_DEG) -> np.ndarray:
    """Length of each segment that lies within ``distance_m`` and ``angle_deg`` of any of ``others``.

    Parameters
    ----------
    segments, others
        Arrays (n, 2, 2) and (m, 2, 2) of segments ``[[x0, z0], [x1, z1]]``.
    distance_m
        Largest distance from a point of a segment to an other segment.
    angle_deg
        Largest angle between the two lines (directions taken modulo 180 degrees, as wall
        face lines have no sense).

    Returns
    -------
    numpy.ndarray
        (n,) covered lengths, in the units of the coordinates.
    """
    segments = np.asarray(segments, dtype=np.float64).reshape(-1, 2, 2)
    others = np.asarray(others, dtype=np.float64).reshape(-1, 2, 2)
    lengths = np.linalg.norm(segments[:, 1] - segments[:, 0], axis=1)
    out = np.zeros(len(segments))
    if not len(segments) or not len(others):
        return out
    ds = segments[:, 1] - segments[:, 0]
    do = others[:, 1] - others[:, 0]
    us = ds / np.maximum(lengths, 1e-12)[:, None]
    uo = do / np.maximum(np.linalg.norm(do, axis=1), 1e-12)[:, None]
    # |cos| of the angle between lines: the sign of a direction means nothing
    parallel = np.abs(us @ uo.T) >= np.cos(np.radians(angle_deg)) - 1e-12
    for i in np.flatnonzero(lengths > 0):
        cand = np.flatnonzero(parallel[i])
        if not len(cand):
            continue
        k = max(1, int(np.ceil(lengths[i] / WALL_SAMPLE_M)))
        t = (np.arange(k) + 0.5) / k
        pts = segments[i, 0] + t[:, None] * ds[i]
        near = _segment_distances(pts, others[cand, 0], others[cand, 1]) <= distance_m + _EPS_M
        out[i] = lengths[i] * np.count_nonzero(near.any(axis=1)) / k
    return out


def wall_scores(pred: np.ndarray, truth: np.ndarray, sure: np.ndarray) -> dict[str, Any]:
    """Length-weighted wall precision, recall, F1 and furniture length of one story.

    Parameters
    ----------
    pred
        (n, 2, 2) predicted wall faces in the plan frame.
    truth
        (m, 2, 2) truth wall face lines in the plan frame.
    sure
        (m,) booleans: which truth walls are sure (only these count in recall).
    """
    pred = np.asarray(pred, dtype=np.float64).reshape(-1, 2, 2)
    truth = np.asarray(truth, dtype=np.float64).reshape(-1, 2, 2)
    sure = np.asarray(sure, dtype=bool).reshape(-1)
    pred_len = float(np.linalg.norm(pred[:, 1] - pred[:, 0], axis=1).sum())
    matched = float(covered_lengths(pred, truth).sum())
    sure_truth = truth[sure]
    sure_len = float(np.linalg.norm(sure_truth[:, 1] - sure_truth[:, 0], axis=1).sum())
    covered = float(covered_lengths(sure_truth, pred).sum())
    return _wall_ratios(
        {
            "walls": len(pred),
            "truth_walls": len(truth),
            "sure_truth_walls": int(sure.sum()),
            "predicted_length_m": pred_len,
            "matched_length_m": matched,
            "sure_length_m": sure_len,
            "covered_sure_length_m": covered,
            "furniture_length_m": max(pred_len - matched, 0.0),
        }
    )


def _wall_ratios(w: dict[str, Any]) -> dict[str, Any]:
    """Adds precision, recall and F1 to summed wall lengths."""
    p = w["matched_length_m"] / w["predicted_length_m"] if w["predicted_length_m"] > 0 else None
    r = w["covered_sure_length_m"] / w["sure_length_m"] if w["sure_length_m"] > 0 else None
    if r is None:
        f1 = None
    elif p is None or p + r == 0:
        f1 = 0.0  # nothing predicted, or nothing right: no credit
    else:
        f1 = 2 * p * r / (p + r)
    return {**w, "precision": p, "recall": r, "f1": f1}


# ----------------------------------------------------------------------------------- rooms


def _polygon(points: Any):
    """A valid shapely polygon (self-touching outlines repaired)."""
    from shapely.geometry import Polygon

    return Polygon(np.asarray(points, dtype=np.float64).reshape(-1, 2)).buffer(0)


def _iou(a, b) -> float:
    if a.is_empty or b.is_empty or not a.intersects(b):
        return 0.0
    union = a.union(b).area
    return float(a.intersection(b).area / union) if union > 0 else 0.0


def room_scores(pred: list[dict], truth: list[dict]) -> dict[str, Any]:
    """One-to-one room matching of one story.

    Parameters
    ----------
    pred
        Plan rooms: ``{"label", "polygon", "area"}`` in the plan frame.
    truth
        Truth rooms: ``{"id", "polygon", "area", "polygon_alt"?, "area_alt"?}``, polygons
        already mapped into the plan frame.
    """
    from scipy.optimize import linear_sum_assignment

    pred_polys = [_polygon(r["polygon"]) for r in pred]
    # per truth room its outlines: (polygon, area, is the alternative)
    outlines = []
    for t in truth:
        alts = [(_polygon(t["polygon"]), float(t.get("area", 0.0)), False)]
        if t.get("polygon_alt") is not None and len(t["polygon_alt"]) >= 3:
            alts.append((_polygon(t["polygon_alt"]), float(t.get("area_alt", 0.0)), True))
        outlines.append([(poly, area if area > 0 else poly.area, alt) for poly, area, alt in alts])
    iou = np.zeros((len(pred), len(truth)))
    which = np.zeros((len(pred), len(truth)), dtype=int)
    for i, pp in enumerate(pred_polys):
        for j, alts in enumerate(outlines):
            scores = [_iou(pp, poly) for poly, _, _ in alts]
            which[i, j] = int(np.argmax(scores))
            iou[i, j] = scores[which[i, j]]
    pairs = []
    if iou.size:
        rows, cols = linear_sum_assignment(-iou)
        for i, j in zip(rows, cols):
            if iou[i, j] < ROOM_IOU_MIN:
                continue
            _, t_area, alt = outlines[j][which[i, j]]
            p_area = float(pred[i].get("area", pred_polys[i].area))
            pairs.append(
                {
                    "truth": truth[j].get("id", j),
                    "plan": pred[i].get("label", i),
                    "iou": float(iou[i, j]),
                    "alt": alt,
                    "truth_area": t_area,
                    "plan_area": p_area,
                    "area_error": abs(p_area - t_area) / t_area if t_area > 0 else None,
                }
            )
    return _room_ratios({"rooms": len(pred), "truth_rooms": len(truth), "pairs": pairs})


def _room_ratios(r: dict[str, Any]) -> dict[str, Any]:
    pairs = r["pairs"]
    errs = [p["area_error"] for p in pairs if p["area_error"] is not None]
    return {
        **r,
        "matched": len(pairs),
        "precision": len(pairs) / r["rooms"] if r["rooms"] else None,
        "recall": len(pairs) / r["truth_rooms"] if r["truth_rooms"] else None,
        "mean_iou": float(np.mean([p["iou"] for p in pairs])) if pairs else None,
        "mean_area_error": float(np.mean(errs)) if errs else None,
    }


# -------------------------------------------------------------------------------- openings


def opening_scores(pred: np.ndarray, truth: np.ndarray, sure: np.ndarray) -> dict[str, Any]:
    """One-to-one opening matching of one story and kind, nearest pairs first.

    Parameters
    ----------
    pred, truth
        (n, 2) and (m, 2) centres in the plan frame.
    sure
        (m,) booleans: which truth openings are sure (only these count in recall).
    """
    pred = np.asarray(pred, dtype=np.float64).reshape(-1, 2)
    truth = np.asarray(truth, dtype=np.float64).reshape(-1, 2)
    sure = np.asarray(sure, dtype=bool).reshape(-1)
    dist = np.linalg.norm(pred[:, None] - truth[None], axis=2)
    pairs = []
    used_p, used_t = set(), set()
    # a stable sort, so that ties go to the earlier opening and the result is reproducible
    for flat in np.argsort(dist, axis=None, kind="stable"):
        i, j = divmod(int(flat), len(truth))
        if dist[i, j] > OPENING_DISTANCE_M + _EPS_M:
            break
        if i in used_p or j in used_t:
            continue
        used_p.add(i)
        used_t.add(j)
        pairs.append({"plan": i, "truth": j, "distance_m": float(dist[i, j]), "sure": bool(sure[j])})
    return _opening_ratios(
        {
            "found": len(pred),
            "truth": len(truth),
            "sure_truth": int(sure.sum()),
            "matched": len(pairs),
            "matched_sure": sum(p["sure"] for p in pairs),
            "pairs": pairs,
        }
    )


def _opening_ratios(o: dict[str, Any]) -> dict[str, Any]:
    return {
        **o,
        "precision": o["matched"] / o["found"] if o["found"] else None,
        "recall": o["matched_sure"] / o["sure_truth"] if o["sure_truth"] else None,
    }


# ----------------------------------------------------------------------------------- stories


def _story_centre(truth: dict, index: int) -> np.ndarray:
    """Centre (x, z) of a truth story: the middle of its rooms and walls."""
    pts = [np.asarray(r["polygon"], float) for r in truth.get("rooms", []) if r["story"] == index]
    pts += [np.asarray([w["start"], w["end"]], float) for w in truth.get("walls", []) if w["story"] == index]
    if not pts:
        return np.zeros(2)
    allp = np.concatenate(pts)
    return 0.5 * (allp.min(axis=0) + allp.max(axis=0))


def _match_story(plan_stories: list[dict], floor: float) -> dict | None:
    """The plan story whose floor is nearest to ``floor``, if within :data:`STORY_MATCH_M`."""
    best = min(plan_stories, key=lambda s: abs(s["floor"] - floor), default=None)
    return best if best is not None and abs(best["floor"] - floor) <= STORY_MATCH_M else None


def _sure(items: list[dict]) -> np.ndarray:
    return np.array([it.get("confidence", "sure") == "sure" for it in items], dtype=bool)


def evaluate_real(plan: dict, truth: dict) -> dict[str, Any]:
    """Every score of a plan against a real-scan truth file (JSON-ready).

    Returns
    -------
    dict
        ``format``, ``scan``, ``gravity_error_deg`` (angle between the plan's up and the
        truth's), ``alignment_error_deg`` (wall yaw, modulo 90 degrees), ``stories`` (per truth
        story: the plan story scored, floor and ceiling errors, walls, rooms, doors, windows),
        ``total`` (the same pooled over the truth stories) and ``unscored_plan_stories``.
    """
    m = truth_to_plan_matrix(plan, truth)
    rot = m[:3, :3] / np.cbrt(abs(np.linalg.det(m[:3, :3])))
    up = rot @ [0.0, 1.0, 0.0]
    gravity = float(np.degrees(np.arccos(np.clip(up[1] / np.linalg.norm(up), -1.0, 1.0))))
    x = rot @ [1.0, 0.0, 0.0]
    yaw = float(np.degrees(np.arctan2(x[2], x[0])) % 90.0)
    plan_stories = plan.get("stories", [])
    plan_walls = plan.get("walls", [])
    plan_openings = plan.get("openings", [])
    stories, scored = [], set()
    for st in truth.get("stories", []):
        index = st["index"]
        centre = _story_centre(truth, index)
        floor = _height(m, centre, st["floor"])
        match = _match_story(plan_stories, floor)
        k = match["index"] if match is not None else None
        scored.add(k)
        ceiling = _height(m, centre, st["ceiling"]) if st.get("ceiling") is not None else None
        t_walls = [w for w in truth.get("walls", []) if w["story"] == index]
        t_segs = np.array(
            [map_truth_xz(m, [w["start"], w["end"]], 0.5 * (w["bottom"] + w["top"])) for w in t_walls]
        ).reshape(-1, 2, 2)
        p_segs = np.array([[w["start"], w["end"]] for w in plan_walls if w["story"] == k], dtype=np.float64).reshape(-1, 2, 2)
        t_rooms = []
        for r in truth.get("rooms", []):
            if r["story"] == index:
                mapped = {**r, "polygon": map_truth_xz(m, r["polygon"], st["floor"])}
                if r.get("polygon_alt") is not None and len(r["polygon_alt"]) >= 3:
                    mapped["polygon_alt"] = map_truth_xz(m, r["polygon_alt"], st["floor"])
                t_rooms.append(mapped)
        entry: dict[str, Any] = {
            "truth_story": index,
            "plan_story": k,
            "truth_floor_in_plan_m": floor,
            "floor_error_m": match["floor"] - floor if match is not None else None,
            "ceiling_error_m": match["ceiling"] - ceiling if match is not None and ceiling is not None else None,
            "ceiling_found": match.get("ceiling_found") if match is not None else None,
            "walls": wall_scores(p_segs, t_segs, _sure(t_walls)),
            "rooms": room_scores([r for r in plan.get("rooms", []) if r["story"] == k], t_rooms),
        }
        for kind, key in (("door", "doors"), ("window", "windows")):
            t_open = [o for o in truth.get(key, []) if o["story"] == index]
            t_centres = np.array([map_truth_xz(m, [o["center"]], 0.5 * (o["bottom"] + o["top"]))[0] for o in t_open]).reshape(-1, 2)
            p_centres = np.array([o["center"] for o in plan_openings if o["kind"] == kind and o["story"] == k], dtype=np.float64).reshape(-1, 2)
            entry[key] = opening_scores(p_centres, t_centres, _sure(t_open))
        stories.append(entry)
    return {
        "format": REAL_REPORT_FORMAT,
        "scan": truth.get("scan"),
        "gravity_error_deg": gravity,
        "alignment_error_deg": min(yaw, 90.0 - yaw),
        "stories": stories,
        "total": _pool(stories),
        "unscored_plan_stories": [s["index"] for s in plan_stories if s["index"] not in scored],
    }


def _pool(stories: list[dict]) -> dict[str, Any]:
    """Scores over all truth stories: summed lengths and counts, then the same ratios."""
    wall_keys = (
        "walls", "truth_walls", "sure_truth_walls", "predicted_length_m", "matched_length_m", "sure_length_m", "covered_sure_length_m", "furniture_length_m"
    )
    total: dict[str, Any] = {"walls": _wall_ratios({k: sum(s["walls"][k] for s in stories) for k in wall_keys})}
    total["rooms"] = _room_ratios(
        {
            "rooms": sum(s["rooms"]["rooms"] for s in stories),
            "truth_rooms": sum(s["rooms"]["truth_rooms"] for s in stories),
            "pairs": [p for s in stories for p in s["rooms"]["pairs"]],
        }
    )
    for key in ("doors", "windows"):
        counts = {k: sum(s[key][k] for s in stories) for k in ("found", "truth", "sure_truth", "matched", "matched_sure")}
        total[key] = _opening_ratios({**counts, "pairs": [p for s in stories for p in s[key]["pairs"]]})
    return total


def _fmt(value: float | None, spec: str = ".3f", scale: float = 1.0, unit: str = "") -> str:
    return "-" if value is None else f"{value * scale:{spec}}{unit}"


def format_real_report(report: dict) -> str:
    """The report of :func:`evaluate_real` as text."""
    lines = [
        f"scan              {report.get('scan') or '-'}",
        f"gravity error     {report['gravity_error_deg']:.3f} deg",
        f"alignment error   {report['alignment_error_deg']:.3f} deg",
    ]
    for s in report["stories"]:
        lines.append("")
        if s["plan_story"] is None:
            lines.append(
                f"truth story {s['truth_story']}: no plan story within {STORY_MATCH_M} m of its floor "
                f"(at y = {s['truth_floor_in_plan_m']:.2f} m in the plan frame)"
            )
        else:
            lines.append(
                f"truth story {s['truth_story']} = plan story {s['plan_story']}: floor error "
                f"{_fmt(s['floor_error_m'], '+.1f', 100, ' cm')}, ceiling error {_fmt(s['ceiling_error_m'], '+.1f', 100, ' cm')}"
            )
        lines.extend("  " + line for line in _format_scores(s))
    if len(report["stories"]) > 1:
        lines.append("")
        lines.append("all stories")
        lines.extend("  " + line for line in _format_scores(report["total"]))
    if report.get("unscored_plan_stories"):
        lines.append(f"plan stories without truth (not scored): {report['unscored_plan_stories']}")
    return "\n".join(lines)


def _format_scores(s: dict) -> list[str]:
    w, r = s["walls"], s["rooms"]
    lines = [
        (
            f"walls     F1 {_fmt(w['f1'])} (precision {_fmt(w['precision'])}, recall {_fmt(w['recall'])}); "
            f"{w['predicted_length_m']:.2f} m predicted, {w['furniture_length_m']:.2f} m furniture"
        ),
        (
            f"rooms     {r['matched']} of {r['truth_rooms']} found, {r['rooms']} predicted: precision {_fmt(r['precision'], '.2f')}, "
            f"recall {_fmt(r['recall'], '.2f')}, mean IoU {_fmt(r['mean_iou'])}, mean area error {_fmt(r['mean_area_error'], '.1f', 100, ' %')}"
        ),
    ]
    for key in ("doors", "windows"):
        o = s[key]
        lines.append(
            f"{key:<9} {o['found']} found, {o['truth']} true ({o['sure_truth']} sure): "
            f"precision {_fmt(o['precision'], '.2f')}, recall {_fmt(o['recall'], '.2f')}"
        )
    return lines
