"""Run meshplan on every real scan, score it against its truth and draw a contact sheet of each.

    python scripts/gallery.py --scans ../shared/scans --truth ../shared/truth --output gallery-out

(``make gallery``). For each scan in ``--scans`` (``*.su_planes.ply`` sidecars are not scans
and are listed as skipped) it runs ``meshplan run``
into ``<output>/runs/<stem>/``, scores ``plan.json`` against ``<truth>/<stem>.truth.json`` where
there is one (:mod:`meshplan.evaluate_real`), and writes

* ``<output>/<stem>.png``: the pen-and-ink plan of story 0 beside its drafting plan drawn from
  plan.json, with the truth walls, rooms, doors and windows overlaid in the plan frame;
* ``<output>/summary.md`` and ``summary.json``: per scan and truth story, the gravity error, floor
  and ceiling errors, wall precision/recall/F1, furniture length, room recall/IoU/area error,
  door recall and the time of the run.

A scan that fails (in meshplan, the scoring or the drawing) is recorded with its error and the
others go on. At most ``--workers`` (2) scans run at once, each drawing in its own process only
(``--set processes=1``), so that the gallery takes no more than two cores.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from meshplan.io.mesh import SCAN_FORMATS

#: Scan formats meshplan reads (meshplan.io's meshes, point clouds and USD stages; a file with
#: another suffix is not a scan).
MESH_SUFFIXES = set(SCAN_FORMATS)
#: Truth of a scan that has none under its own name: the RoomPlan USDZ exports are the stages
#: the ``*_parametric.ply`` files were converted from, in the same world coordinates and metres
#: (../shared/scans/MANIFEST.md), so the PLY's truth scores them.
TRUTH_ALIASES = {
    "roomplan_sekhar_library.usdz": "roomplan_sekhar_library_parametric",
    "roomplan_sekhar_small_room.usdz": "roomplan_sekhar_small_room_parametric",
}
#: Files beside the scans that are not scans of their own: the HoloLens 2 device's plane quads.
SIDECAR_SUFFIX = ".su_planes.ply"
#: Formats meshplan cannot read yet, listed as skipped with this reason.
#: Extensions of files in the scans folder that are not scans meshplan reads (none today: USDZ
#: is read since issue 14); kept so that a new kind of sidecar can be listed as skipped.
UNREADABLE: dict[str, str] = {}
#: Longest a single scan may take (s) before it is recorded as failed.
RUN_TIMEOUT_S = 900
#: The contact sheet's size (inches) and resolution.
SHEET_SIZE_IN = (16.0, 8.0)
SHEET_DPI = 110
#: Longest note (characters) in a row of summary.md.
NOTE_CHARS = 60


def list_scans(scans: Path) -> tuple[list[Path], list[dict[str, str]]]:
    """The scans to run and the files skipped (with the reason)."""
    run, skipped = [], []
    for path in sorted(scans.iterdir()):
        if not path.is_file():
            continue
        name = path.name.lower()
        if name.endswith(SIDECAR_SUFFIX):
            skipped.append({"scan": path.name, "reason": "HoloLens 2 plane sidecar, not a scan"})
        elif path.suffix.lower() in UNREADABLE:
            skipped.append({"scan": path.name, "reason": UNREADABLE[path.suffix.lower()]})
        elif path.suffix.lower() in MESH_SUFFIXES:
            run.append(path)
    return run, skipped


def manifest_ups(manifest: Path) -> dict[str, np.ndarray]:
    """Up vectors (input frame) of the scans in MANIFEST.md: its ``(x, y, z)`` column, or +y for
    the files listed after the line saying that up is +y in every file below."""
    ups: dict[str, np.ndarray] = {}
    if not manifest.is_file():
        return ups
    all_y = False
    for line in manifest.read_text(encoding="utf-8").splitlines():
        if "Up is +y in every file below" in line:
            all_y = True
        m = re.match(r"\|\s*`([^`]+)`\s*\|", line)
        if not m:
            continue
        vec = re.search(r"\|\s*\((-?[\d.]+),\s*(-?[\d.]+),\s*(-?[\d.]+)\)\s*\|", line)
        if vec:
            ups[m.group(1)] = np.array([float(v) for v in vec.groups()])
        elif all_y:
            ups[m.group(1)] = np.array([0.0, 1.0, 0.0])
    return ups


def run_scan(scan: Path, out: Path, settings: tuple[str, ...] = ()) -> dict[str, Any]:
    """``meshplan run`` on one scan in a fresh process (with ``--set`` of each of ``settings``,
    ``NAME=VALUE``): status, error line and wall-clock time."""
    cmd = [sys.executable, "-m", "meshplan", "run", str(scan), "-o", str(out), "--force", "--quiet", "--set", "processes=1"]
    cmd += [arg for setting in settings for arg in ("--set", setting)]
    t0 = time.perf_counter()
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=RUN_TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        return {"status": "failed", "error": f"timed out after {RUN_TIMEOUT_S} s", "time_s": time.perf_counter() - t0}
    elapsed = time.perf_counter() - t0
    if proc.returncode != 0:
        lines = [ln for ln in proc.stderr.splitlines() if ln.strip()]
        return {"status": "failed", "error": lines[-1] if lines else f"exit status {proc.returncode}", "time_s": elapsed}
    return {"status": "ok", "error": None, "time_s": elapsed}


def previous_run(scan: Path, out: Path) -> dict[str, Any]:
    """The result of an earlier run in ``out`` (for ``--rescore``)."""
    try:
        plan = json.loads((out / "plan.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {"scan": scan.name, "status": "failed", "error": f"no earlier run in {out}", "time_s": None}
    return {"scan": scan.name, "status": "ok", "error": None, "time_s": (plan.get("timings") or {}).get("total")}


def angle_deg(a: np.ndarray, b: np.ndarray) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    c = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def plan_up(plan: dict) -> np.ndarray:
    """The plan's up in input coordinates: row 1 of its transform's rotation."""
    return np.asarray(plan["transform"], float)[1, :3]


# ----------------------------------------------------------------------------- contact sheet


def _segment(center, direction, width) -> np.ndarray:
    c = np.asarray(center, float)
    d = np.asarray(direction, float)
    d = d / max(np.linalg.norm(d), 1e-12)
    return np.array([c - 0.5 * width * d, c + 0.5 * width * d])


def draw_sheet(path: Path, stem: str, run_dir: Path, plan: dict, truth: dict | None, report: dict | None) -> None:
    """The contact sheet of a scan's story 0 (see the module docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from meshplan.evaluate_real import map_truth_xz, truth_to_plan_matrix

    fig, (ax_ink, ax) = plt.subplots(1, 2, figsize=SHEET_SIZE_IN, gridspec_kw={"width_ratios": [1, 1]})
    ink = run_dir / "pen-and-ink-0.png"
    if ink.is_file():
        ax_ink.imshow(plt.imread(str(ink)))
    ax_ink.set_axis_off()
    ax_ink.set_title("pen-and-ink, story 0 (meshplan)", fontsize=9)

    walls = [w for w in plan.get("walls", []) if w["story"] == 0]
    for r in (r for r in plan.get("rooms", []) if r["story"] == 0):
        p = np.asarray(r["polygon"], float)
        ax.fill(p[:, 0], p[:, 1], color="#bbbbbb", alpha=0.35, lw=0)
        c = p.mean(axis=0)
        ax.text(c[0], c[1], f"{r['label']}\n{r['area']:.1f} m2", fontsize=6, ha="center", va="center", color="#444444")
    for w in walls:
        s, e = np.asarray(w["start"]), np.asarray(w["end"])
        ax.plot([s[0], e[0]], [s[1], e[1]], color="black", lw=2.2, solid_capstyle="butt")
    for o in (o for o in plan.get("openings", []) if o["story"] == 0):
        w = plan["walls"][o["wall"]] if 0 <= o["wall"] < len(plan["walls"]) else None
        d = np.subtract(w["end"], w["start"]) if w is not None else np.array([1.0, 0.0])
        seg = _segment(o["center"], d, o["width"])
        ax.plot(seg[:, 0], seg[:, 1], color="#2ca02c" if o["kind"] == "door" else "#17becf", lw=5, alpha=0.8, solid_capstyle="butt")

    if truth is not None:
        m = truth_to_plan_matrix(plan, truth)
        stories = {s["truth_story"] for s in (report or {}).get("stories", []) if s["plan_story"] == 0}
        if not stories and truth["stories"]:
            # no truth story at plan story 0's floor (up found wrong, a story missed): overlay the
            # truth's story 0 anyway, so that the sheet shows how far off the plan is
            stories = {truth["stories"][0]["index"]}
        floors = {s["index"]: s["floor"] for s in truth["stories"]}
        for w in (w for w in truth["walls"] if w["story"] in stories):
            seg = map_truth_xz(m, [w["start"], w["end"]], 0.5 * (w["bottom"] + w["top"]))
            ax.plot(seg[:, 0], seg[:, 1], color="red", lw=1.0, ls="-" if w["confidence"] == "sure" else "--")
        for r in (r for r in truth["rooms"] if r["story"] in stories):
            p = map_truth_xz(m, r["polygon"], floors[r["story"]])
            p = np.vstack([p, p[:1]])
            ax.plot(p[:, 0], p[:, 1], color="purple", lw=0.9, ls=":")
        for key, color in (("doors", "blue"), ("windows", "deepskyblue")):
            for o in (o for o in truth.get(key, []) if o["story"] in stories):
                w = truth["walls"][o["wall"]]
                c = map_truth_xz(m, [o["center"]], 0.5 * (o["bottom"] + o["top"]))[0]
                d = map_truth_xz(m, [w["end"]], 0.0)[0] - map_truth_xz(m, [w["start"]], 0.0)[0]
                seg = _segment(c, d, o["width"])
                ax.plot(seg[:, 0], seg[:, 1], color=color, lw=2.0, ls="-" if o["confidence"] == "sure" else "--")
                ax.plot(*c, marker="o", ms=3, color=color)
    ax.set_aspect("equal")
    ax.invert_yaxis()  # z down the page, as meshplan draws its plans
    ax.grid(True, lw=0.3, alpha=0.5)
    ax.set_xlabel("x (m)", fontsize=7)
    ax.set_ylabel("z (m)", fontsize=7)
    ax.tick_params(labelsize=6)
    handles = [
        Line2D([], [], color="black", lw=2.2, label="meshplan walls"),
        Line2D([], [], color="#2ca02c", lw=5, label="meshplan doors"),
        Line2D([], [], color="#17becf", lw=5, label="meshplan windows"),
        Line2D([], [], color="red", lw=1, label="truth walls (dashed unsure)"),
        Line2D([], [], color="purple", lw=1, ls=":", label="truth rooms"),
        Line2D([], [], color="blue", lw=2, label="truth doors"),
        Line2D([], [], color="deepskyblue", lw=2, label="truth windows"),
    ]
    # below the drawing, where it hides nothing
    ax.legend(handles=handles, fontsize=6, loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=4, frameon=False)
    ax.set_title("drafting, story 0: meshplan (grey, black) and truth (colours)", fontsize=9)
    fig.suptitle(f"{stem}   {sheet_caption(report)}", fontsize=10)
    # the caption above both panels, the legend below the drafting plan: both inside the sheet
    # whatever the panels' aspect (tight_layout alone let a tall pen-and-ink image run under
    # the caption and the legend off the bottom)
    fig.tight_layout(rect=(0.0, 0.08, 1.0, 0.95))
    fig.savefig(path, dpi=SHEET_DPI)
    plt.close(fig)


def sheet_caption(report: dict | None) -> str:
    if report is None:
        return "(no truth)"
    s0 = next((s for s in report["stories"] if s["plan_story"] == 0), None)
    if s0 is None:
        s = report["stories"][0]
        return (
            f"no truth story at plan story 0's floor: truth story {s['truth_story']} (overlaid) has its floor at "
            f"y = {s['truth_floor_in_plan_m']:.2f} m in the plan; gravity error {report['gravity_error_deg']:.1f} deg"
        )
    w, r, d = s0["walls"], s0["rooms"], s0["doors"]
    return (
        f"walls P {fmt(w['precision'])} R {fmt(w['recall'])} F1 {fmt(w['f1'])}, "
        f"rooms R {fmt(r['recall'])} IoU {fmt(r['mean_iou'])}, doors R {fmt(d['recall'])}"
    )


# ----------------------------------------------------------------------------------- summary


def fmt(v: float | None, spec: str = ".2f", scale: float = 1.0) -> str:
    return "-" if v is None else f"{v * scale:{spec}}"


def summary_rows(results: list[dict]) -> list[list[str]]:
    rows = []
    for res in results:
        base = [res["scan"], res["status"] if res["status"] != "failed" else "failed", fmt(res.get("time_s"), ".1f"), fmt(res.get("gravity_error_deg"), ".2f")]
        report = res.get("report")
        if report is None:
            note = res.get("error") or ("no truth" if res["status"] == "ok" else "")
            if len(note) > NOTE_CHARS:  # the whole error is listed under the table
                note = note[: NOTE_CHARS - 3] + "..."
            rows.append(base[:1] + ["-"] + base[1:] + ["-"] * 11 + [note])
            continue
        for s in report["stories"]:
            w, r, d = s["walls"], s["rooms"], s["doors"]
            note = "" if s["plan_story"] is not None else f"no plan story at this floor (truth floor at y = {s['truth_floor_in_plan_m']:.2f} m in the plan)"
            rows.append(
                base[:1]
                + [f"{s['truth_story']}" + (f"={s['plan_story']}" if s["plan_story"] is not None else "")]
                + base[1:]
                + [
                    fmt(s["floor_error_m"], "+.1f", 100),
                    fmt(s["ceiling_error_m"], "+.1f", 100),
                    fmt(w["precision"]),
                    fmt(w["recall"]),
                    fmt(w["f1"]),
                    fmt(w["furniture_length_m"], ".1f"),
                    f"{r['matched']}/{r['truth_rooms']}",
                    fmt(r["mean_iou"]),
                    fmt(r["mean_area_error"], ".0f", 100),
                    f"{d['matched_sure']}/{d['sure_truth']}" if d["sure_truth"] else "-",
                    fmt(d["precision"]),
                    note,
                ]
            )
    return rows


HEADER = [
    "scan", "story (truth=plan)", "status", "time s", "gravity deg", "floor cm", "ceiling cm", "wall P", "wall R", "wall F1",
    "furniture m", "rooms found", "room IoU", "area err %", "doors found (sure)", "door P", "note",
]


def write_summary(out: Path, results: list[dict], skipped: list[dict]) -> str:
    lines = [
        "# meshplan on the real scans",
        "",
        (
            "Scored against `../shared/truth` (truth README rules: walls within 15 cm and 10 degrees, rooms one-to-one at IoU >= 0.5, "
            "openings within 40 cm). Gravity: angle between the plan's up and the truth's "
            "(or, without truth, the truth README's levelling of the scan from MANIFEST.md's up). "
            "Floor/ceiling: plan minus truth at the centre of the story. Time: wall-clock `meshplan run` (2 scans at once)."
        ),
        "",
        "| " + " | ".join(HEADER) + " |",
        "|" + "---|" * len(HEADER),
    ]
    lines += ["| " + " | ".join(row) + " |" for row in summary_rows(results)]
    if skipped:
        lines += ["", "Skipped:", ""] + [f"- `{s['scan']}`: {s['reason']}" for s in skipped]
    failed = [r for r in results if r["status"] == "failed"]
    if failed:
        lines += ["", "Failed:", ""] + [f"- `{r['scan']}`: {r['error']}" for r in failed]
    text = "\n".join(lines) + "\n"
    (out / "summary.md").write_text(text, encoding="utf-8")
    (out / "summary.json").write_text(json.dumps({"scans": results, "skipped": skipped}, indent=1) + "\n", encoding="utf-8")
    return text


def score_and_draw(scan: Path, res: dict, out: Path, truth_dir: Path, ups: dict[str, np.ndarray]) -> None:
    """Evaluation, gravity error and contact sheet of a finished run (errors recorded in ``res``)."""
    from meshplan.evaluate_real import evaluate_real

    run_dir = out / "runs" / scan.stem
    try:
        plan = json.loads((run_dir / "plan.json").read_text(encoding="utf-8"))
        res["plan_stories"] = len(plan.get("stories", []))
        truth_path = truth_dir / f"{TRUTH_ALIASES.get(scan.name, scan.stem)}.truth.json"
        truth = json.loads(truth_path.read_text(encoding="utf-8")) if truth_path.is_file() else None
        report = None
        if truth is not None:
            report = evaluate_real(plan, truth)
            up = np.asarray(truth["truth_to_input"], float)[:3, :3] @ [0.0, 1.0, 0.0]
            res["gravity_ref"] = "truth"
        elif scan.name in ups:
            # no truth: the truth's own levelling of the scan, from the manifest's up
            from meshplan.evaluate_real import truth_levelling
            from meshplan.io import load_mesh

            mesh = load_mesh(scan).mesh
            up = truth_levelling(mesh.face_centroids, mesh.face_normals, mesh.face_areas, ups[scan.name])
            res["gravity_ref"] = "truth levelling"
        else:
            up = None
        res["gravity_error_deg"] = angle_deg(plan_up(plan), up) if up is not None else None
        res["report"] = report
        draw_sheet(out / f"{scan.stem}.png", scan.stem, run_dir, plan, truth, report)
    except Exception as exc:  # noqa: BLE001 -- one bad scan must not stop the gallery
        res["status"] = "failed"
        res["error"] = f"scoring or drawing: {type(exc).__name__}: {exc}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scans", type=Path, default=Path("../shared/scans"))
    ap.add_argument("--truth", type=Path, default=Path("../shared/truth"))
    ap.add_argument("--output", "-o", type=Path, default=Path("gallery-out"))
    ap.add_argument("--workers", "-j", type=int, default=2, help="scans run at once (each in one process)")
    ap.add_argument(
        "--rescore", action="store_true",
        help="score and draw the runs already in OUTPUT/runs without running meshplan again (time: plan.json's timings)",
    )
    ap.add_argument(
        "--set", dest="settings", action="append", default=[], metavar="NAME=VALUE",
        help="a parameter for every run (meshplan run --set), e.g. to see what a default's change does to every scan; repeatable",
    )
    args = ap.parse_args(argv)
    if not args.scans.is_dir():
        print(f"error: {args.scans}: no such directory; give --scans (the real scans, ../shared/scans)", file=sys.stderr)
        return 2
    scans, skipped = list_scans(args.scans)
    ups = manifest_ups(args.scans / "MANIFEST.md")
    (args.output / "runs").mkdir(parents=True, exist_ok=True)

    def one(scan: Path) -> dict:
        if args.rescore:
            return previous_run(scan, args.output / "runs" / scan.stem)
        res = {"scan": scan.name, **run_scan(scan, args.output / "runs" / scan.stem, tuple(args.settings))}
        print(f"{scan.name}: {res['status']} in {res['time_s']:.1f} s" + (f" ({res['error']})" if res["error"] else ""), file=sys.stderr, flush=True)
        return res

    with ThreadPoolExecutor(max_workers=max(1, args.workers)) as pool:
        results = list(pool.map(one, scans))
    for scan, res in zip(scans, results):
        if res["status"] == "ok":
            score_and_draw(scan, res, args.output, args.truth, ups)
    print(write_summary(args.output, results, skipped))
    return 0


if __name__ == "__main__":
    sys.exit(main())
