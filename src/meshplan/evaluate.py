"""Comparing a result (plan.json) with the ground truth of a synthetic scan (truth.json).

A real scan's hand-digitized truth (``<scan>.truth.json``, recognised by its ``truth_to_input``)
is scored by :mod:`meshplan.evaluate_real` instead: :func:`evaluate` and :func:`format_report`
hand it over, so that ``meshplan evaluate`` takes either kind of truth.

The truth is mapped into the plan frame by ``plan.transform @ truth.transform`` (truth frame to
scan coordinates to plan frame), so no alignment is estimated: every error meshplan made,
orientation included, shows. The report has the paper's Table 2 (room, true area, computed
area, error %) plus wall, door, gravity and height errors.

Matching rules
--------------
* A computed wall matches a true wall face when their normals are within 5 degrees, the true
  face's middle is within 10 cm of the computed wall's plane, and they overlap along the wall by
  at least half of the shorter one. Precision and recall are weighted by length.
* A computed room matches the true room it overlaps most when their intersection over union is
  at least 0.5.
* A computed opening matches a true opening of the same kind whose centre is within 30 cm and
  whose wall faces the same way.
* A computed stair matches the true stair of its story whose footprint it overlaps most, at an
  intersection over union of at least 0.5; its riser count, rise and the stories it connects are
  compared (a synthetic stair joins its story to the next).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .errors import InputError

WALL_ANGLE_DEG = 5.0
WALL_OFFSET_M = 0.10
WALL_OVERLAP = 0.5
ROOM_IOU = 0.5
OPENING_DISTANCE_M = 0.30
STAIR_IOU = 0.5


def truth_to_plan(plan: dict, truth: dict) -> np.ndarray:
    """4x4 transform from the truth frame to the plan frame."""
    try:
        m = np.asarray(plan["transform"], dtype=np.float64)
        t = np.asarray(truth["transform"], dtype=np.float64)
    except (KeyError, ValueError, TypeError):
        raise InputError("plan or truth file has no valid 'transform'", "give a plan.json and a synthetic truth.json") from None
    if m.shape != (4, 4) or t.shape != (4, 4):
        raise InputError("'transform' must be a 4x4 matrix", "give a plan.json and a synthetic truth.json")
    return m @ t


def _map_xz(p: np.ndarray, xz: ArrayLike, y: float) -> np.ndarray:
    xz = np.asarray(xz, dtype=np.float64).reshape(-1, 2)
    pts = np.c_[xz[:, 0], np.full(len(xz), y), xz[:, 1], np.ones(len(xz))] @ p.T
    return pts[:, [0, 2]]


def _map_dir(p: np.ndarray, d: ArrayLike) -> np.ndarray:
    d = np.asarray(d, dtype=np.float64).reshape(-1, 2)
    v = np.c_[d[:, 0], np.zeros(len(d)), d[:, 1]] @ p[:3, :3].T
    v = v[:, [0, 2]]
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def mapped_truth_walls(p: np.ndarray, truth: dict) -> list[dict]:
    out = []
    for w in truth.get("walls", []):
        mid_y = 0.5 * (w["bottom"] + w["top"])
        s, e = _map_xz(p, [w["start"], w["end"]], mid_y)
        out.append({"story": w["story"], "start": s, "end": e, "normal": _map_dir(p, w["normal"])[0]})
    return out


def _wall_match(d: dict, t: dict) -> tuple[bool, float]:
    nd = np.asarray(d["normal"], float)
    nd = nd / np.linalg.norm(nd)
    if float(nd @ t["normal"]) < np.cos(np.radians(WALL_ANGLE_DEG)):
        return False, np.inf
    ds, de = np.asarray(d["start"], float), np.asarray(d["end"], float)
    mid_t = 0.5 * (t["start"] + t["end"])
    offset = abs(float(nd @ (mid_t - ds)))
    if offset > WALL_OFFSET_M:
        return False, offset
    tang = np.array([-nd[1], nd[0]])
    a0, a1 = sorted((float(tang @ ds), float(tang @ de)))
    b0, b1 = sorted((float(tang @ t["start"]), float(tang @ t["end"])))
    overlap = min(a1, b1) - max(a0, b0)
    shorter = min(a1 - a0, b1 - b0)
    return overlap >= WALL_OVERLAP * shorter and overlap > 0, offset


def wall_scores(plan_walls: list[dict], true_walls: list[dict]) -> dict[str, Any]:
    """Length-weighted precision, recall and F1 of the walls, and the offsets of matches."""
    len_d = [float(np.linalg.norm(np.subtract(w["end"], w["start"]))) for w in plan_walls]
    len_t = [float(np.linalg.norm(w["end"] - w["start"])) for w in true_walls]
    matched_d = np.zeros(len(plan_walls), bool)
    matched_t = np.zeros(len(true_walls), bool)
    offsets = []
    for i, d in enumerate(plan_walls):
        best = np.inf
        for j, t in enumerate(true_walls):
            if t["story"] != d["story"]:
                continue
            ok, off = _wall_match(d, t)
            if ok:
                matched_d[i] = matched_t[j] = True
                best = min(best, off)
        if np.isfinite(best):
            offsets.append(best)
    precision = float(np.dot(matched_d, len_d) / max(sum(len_d), 1e-12)) if plan_walls else 0.0
    recall = float(np.dot(matched_t, len_t) / max(sum(len_t), 1e-12)) if true_walls else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return {
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "median_offset_m": float(np.median(offsets)) if offsets else None,
        "walls": len(plan_walls),
        "true_walls": len(true_walls),
    }


def room_scores(plan_rooms: list[dict], truth: dict, p: np.ndarray) -> dict[str, Any]:
    """The paper's Table 2 rows, found rooms and area errors."""
    from shapely.geometry import Polygon

    rows = []
    computed = [(r, Polygon(r["polygon"]).buffer(0)) for r in plan_rooms]
    found = 0
    for t in truth.get("rooms", []):
        story_floor = truth["stories"][t["story"]]["floor"]
        poly = Polygon(_map_xz(p, t["polygon"], story_floor)).buffer(0)
        best, best_iou = None, 0.0
        for r, cp in computed:
            if r["story"] != t["story"] or not cp.intersects(poly):
                continue
            iou = cp.intersection(poly).area / cp.union(poly).area
            if iou > best_iou:
                best, best_iou = r, iou
        match = best if best is not None and best_iou >= ROOM_IOU else None
        found += match is not None
        rows.append(
            {
                "room": t["label"],
                "story": t["story"],
                "true_area": t["area"],
                "computed_label": match["label"] if match is not None else None,
                "computed_area": match["area"] if match is not None else None,
                "error_pct": 100.0 * (t["area"] - match["area"]) / t["area"] if match is not None else None,
                "iou": best_iou,
            }
        )
    errs = [abs(r["error_pct"]) for r in rows if r["error_pct"] is not None and r["true_area"] >= 4.0]
    # computed rooms that match no true room (a room split in two, a space outside the building)
    true_polys = [
        (t["story"], Polygon(_map_xz(p, t["polygon"], truth["stories"][t["story"]]["floor"])).buffer(0)) for t in truth.get("rooms", [])
    ]
    extra = [
        r["label"]
        for r, cp in computed
        if not any(s == r["story"] and cp.intersects(tp) and cp.intersection(tp).area / cp.union(tp).area >= ROOM_IOU for s, tp in true_polys)
    ]
    return {
        "rows": rows,
        "found": found,
        "computed_rooms": len(computed),
        "extra": extra,
        "precision": (len(computed) - len(extra)) / len(computed) if computed else None,
        "true_rooms": len(rows),
        "found_fraction": found / len(rows) if rows else None,
        "median_abs_error_pct": float(np.median(errs)) if errs else None,
        "p90_abs_error_pct": float(np.percentile(errs, 90)) if errs else None,
    }


def opening_scores(plan_openings: list[dict], plan_walls: list[dict], truth: dict, p: np.ndarray, kind: str) -> dict[str, Any]:
    """Precision, recall and width errors of one kind of opening, per physical opening.

    The synthetic truth lists an interior opening once per wall face it passes through, under
    one label; those faces are one opening, which a found opening matches through any of them
    (meshplan reports each physical opening once). Openings without a label are their own.
    """
    groups: dict[tuple, list[dict]] = {}
    for i, o in enumerate(truth.get("openings", [])):
        if o["kind"] != kind:
            continue
        w = truth["walls"][o["wall"]]
        c = _map_xz(p, [o["center"]], 0.5 * (o["bottom"] + o["top"]))[0]
        key = (o["story"], o["label"]) if o.get("label") else (o["story"], f"#{i}")
        groups.setdefault(key, []).append({"story": o["story"], "center": c, "normal": _map_dir(p, w["normal"])[0], "width": o["width"]})
    true = list(groups.values())
    found = [o for o in plan_openings if o["kind"] == kind]
    used = np.zeros(len(true), bool)
    width_err = []
    tp = 0
    for o in found:
        n = np.asarray(plan_walls[o["wall"]]["normal"], float) if 0 <= o["wall"] < len(plan_walls) else np.zeros(2)
        best, best_d = None, OPENING_DISTANCE_M
        for j, faces in enumerate(true):
            if used[j]:
                continue
            for t in faces:
                if t["story"] != o["story"] or float(n @ t["normal"]) < 0.9:
                    continue
                dist = float(np.linalg.norm(np.subtract(o["center"], t["center"])))
                if dist <= best_d:
                    best, best_d = j, dist
        if best is not None:
            used[best] = True
            tp += 1
            width_err.append(abs(o["width"] - true[best][0]["width"]))
    return {
        "found": len(found),
        "true": len(true),
        "precision": tp / len(found) if found else (1.0 if not true else 0.0),
        "recall": tp / len(true) if true else 1.0,
        "median_width_error_m": float(np.median(width_err)) if width_err else None,
        "max_width_error_m": float(np.max(width_err)) if width_err else None,
    }


def stair_scores(plan_stairs: list[dict], truth: dict, p: np.ndarray) -> dict[str, Any]:
    """Per true stair: the matching computed stair's footprint IoU, riser count, rise error and
    the stories it connects; with precision and recall."""
    from shapely.geometry import Polygon

    from .synthetic.truth import stair_footprint

    computed = [(s, Polygon(s["footprint"]).buffer(0)) for s in plan_stairs]
    used: set[int] = set()
    rows = []
    for t in truth.get("stairs", []):
        floor = truth["stories"][t["story"]]["floor"]
        poly = Polygon(_map_xz(p, stair_footprint(t), floor)).buffer(0)
        best, best_iou = None, 0.0
        for k, (s, sp) in enumerate(computed):
            if s["story"] != t["story"] or k in used or not sp.intersects(poly):
                continue
            iou = sp.intersection(poly).area / sp.union(poly).area
            if iou > best_iou:
                best, best_iou = k, iou
        match = computed[best][0] if best is not None and best_iou >= STAIR_IOU else None
        if match is not None and best is not None:
            used.add(best)
        rows.append(
            {
                "story": t["story"],
                "to_story": t["story"] + 1,
                "true_risers": t["risers"],
                "true_rise": t["rise"],
                "iou": best_iou,
                "found": match is not None,
                "risers": match["risers"] if match else None,
                "risers_exact": match is not None and match["risers"] == t["risers"],
                "rise_error_m": abs(match["rise"] - t["rise"]) if match else None,
                "connects": match is not None and match["to_story"] == t["story"] + 1,
            }
        )
    found = sum(r["found"] for r in rows)
    errs = [r["rise_error_m"] for r in rows if r["rise_error_m"] is not None]
    return {
        "rows": rows,
        "found": found,
        "true": len(rows),
        "computed": len(computed),
        "precision": len(used) / len(computed) if computed else (1.0 if not rows else 0.0),
        "recall": found / len(rows) if rows else 1.0,
        "risers_exact": sum(r["risers_exact"] for r in rows),
        "connects": sum(r["connects"] for r in rows),
        "min_iou": min((r["iou"] for r in rows), default=None),
        "max_rise_error_m": max(errs) if errs else None,
    }


def evaluate(plan: dict, truth: dict) -> dict[str, Any]:
    """Every score of a result against ground truth (JSON-ready).

    A real-scan truth (it has ``truth_to_input``) is scored by
    :func:`meshplan.evaluate_real.evaluate_real`; a synthetic truth here.
    """
    from .evaluate_real import evaluate_real, is_real_truth

    if is_real_truth(truth):
        return evaluate_real(plan, truth)
    p = truth_to_plan(plan, truth)
    gravity = float(np.degrees(np.arccos(np.clip((p[:3, :3] @ [0, 1, 0])[1], -1, 1))))
    x = p[:3, :3] @ [1, 0, 0]
    yaw = float(np.degrees(np.arctan2(x[2], x[0])) % 90.0)
    heights = []
    rooms = truth.get("rooms", [])
    for st in truth.get("stories", []):
        story_rooms = [r for r in rooms if r["story"] == st["index"]] or rooms
        c = np.mean(np.array(story_rooms[0]["polygon"]), axis=0) if story_rooms else np.zeros(2)
        computed = next((s for s in plan.get("stories", []) if s["index"] == st["index"]), None)
        for key in ("floor", "ceiling"):
            true_h = float((p @ [c[0], st[key], c[1], 1.0])[1])
            heights.append(
                {"story": st["index"], "level": key, "true": true_h, "computed": computed[key] if computed else None,
                 "error_m": abs(computed[key] - true_h) if computed else None}
            )
    plan_walls = plan.get("walls", [])
    report = {
        "gravity_error_deg": gravity,
        "alignment_error_deg": min(yaw, 90.0 - yaw),
        "stories": {"computed": len(plan.get("stories", [])), "true": len(truth.get("stories", []))},
        "heights": heights,
        "walls": wall_scores(plan_walls, mapped_truth_walls(p, truth)),
    }
    if "rooms" in plan:
        report["rooms"] = room_scores(plan["rooms"], truth, p)
    if "openings" in plan:
        report["doors"] = opening_scores(plan["openings"], plan_walls, truth, p, "door")
        report["windows"] = opening_scores(plan["openings"], plan_walls, truth, p, "window")
    if "stairs" in plan:
        report["stairs"] = stair_scores(plan["stairs"], truth, p)
    return report


def format_report(report: dict) -> str:
    """The report as text, with the paper's Table 2 for the rooms."""
    from .evaluate_real import REAL_REPORT_FORMAT, format_real_report

    if report.get("format") == REAL_REPORT_FORMAT:
        return format_real_report(report)
    lines = []
    lines.append(f"gravity error     {report['gravity_error_deg']:.3f} deg")
    lines.append(f"alignment error   {report['alignment_error_deg']:.3f} deg")
    s = report["stories"]
    lines.append(f"stories           {s['computed']} computed, {s['true']} true")
    for h in report["heights"]:
        err = f"{h['error_m'] * 100:.1f} cm" if h["error_m"] is not None else "missing"
        lines.append(f"story {h['story']} {h['level']:<8s} error {err}")
    w = report["walls"]
    off = f"{w['median_offset_m'] * 100:.1f} cm" if w["median_offset_m"] is not None else "-"
    lines.append(
        f"walls             F1 {w['f1']:.3f} (precision {w['precision']:.3f}, recall {w['recall']:.3f}), median offset {off}"
    )
    if "rooms" in report:
        r = report["rooms"]
        lines.append("")
        lines.append(f"{'Room':<16}{'Area':>10}{'Computed':>10}{'Err %':>8}")
        for row in r["rows"]:
            comp = f"{row['computed_area']:.3f}" if row["computed_area"] is not None else "-"
            err = f"{row['error_pct']:.1f}" if row["error_pct"] is not None else "-"
            lines.append(f"{row['room']:<16}{row['true_area']:>10.3f}{comp:>10}{err:>8}")
        med = r["median_abs_error_pct"]
        p90 = r["p90_abs_error_pct"]
        lines.append(
            f"rooms found {r['found']}/{r['true_rooms']}; |error| over rooms >= 4 m2: median "
            + (f"{med:.2f} %, 90th percentile {p90:.2f} %" if med is not None else "-")
        )
        if r.get("extra"):
            lines.append(f"rooms matching no true room: {', '.join(r['extra'])}")
    for kind in ("doors", "windows"):
        if kind in report:
            d = report[kind]
            werr = f"{d['median_width_error_m'] * 100:.1f} cm" if d["median_width_error_m"] is not None else "-"
            lines.append(f"{kind:<8} {d['found']} found, {d['true']} true: precision {d['precision']:.2f}, recall {d['recall']:.2f}, median width error {werr}")
    if "stairs" in report:
        s = report["stairs"]
        iou = f"{s['min_iou']:.2f}" if s["min_iou"] is not None else "-"
        rerr = f"{s['max_rise_error_m'] * 100:.1f} cm" if s["max_rise_error_m"] is not None else "-"
        lines.append(
            f"stairs   {s['found']}/{s['true']} found ({s['computed']} computed): risers exact {s['risers_exact']}, "
            f"connecting the right stories {s['connects']}, footprint IoU >= {iou}, rise error <= {rerr}"
        )
    return "\n".join(lines)
