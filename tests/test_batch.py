"""``meshplan batch``: many scans, one directory each, a summary (CSV and JSON), per-scan errors
that do not stop the batch, re-runs that keep what was written, local workers and Dask."""

from __future__ import annotations

import csv
import hashlib
import io
import json
import shutil
import sys
from pathlib import Path

import pytest

from meshplan.batch import SUMMARY_COLUMNS
from meshplan.cli import main
from meshplan.export.synth import write_synthetic
from meshplan.synthetic import SynthParams, generate

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")

#: The small rooms of the batch: (directory, seed, format). Coarse triangles keep each run ~1 s.
ROOMS = (("r0", 0, "obj"), ("r1", 1, "obj"), ("r2", 2, "ply"))
BAD = "bad.ply"


@pytest.fixture(scope="module")
def scans(tmp_path_factory) -> Path:
    """A directory of three small synthetic rooms (each in its own directory, with its
    annotations.json) and one garbage file with a mesh extension."""
    root = tmp_path_factory.mktemp("batch") / "scans"
    for name, seed, fmt in ROOMS:
        write_synthetic(generate(SynthParams(preset="room", seed=seed, triangle_size_m=(0.12, 0.2))), root / name, fmt)
    (root / BAD).write_bytes(b"\x00\xffnot a mesh\x13\x37" * 64)
    return root


@pytest.fixture(scope="module")
def batch1(scans, tmp_path_factory) -> tuple[int, Path, dict]:
    """``meshplan batch scans -o out --json`` with one process: (exit status, output, printed JSON)."""
    out = tmp_path_factory.mktemp("batch1") / "out"
    buf = io.StringIO()
    old, sys.stdout = sys.stdout, buf
    try:
        code = main(["batch", str(scans), "-o", str(out), "--json"])
    finally:
        sys.stdout = old
    return code, out, json.loads(buf.getvalue())


def _csv(out: Path) -> list[dict[str, str]]:
    with open(out / "summary.csv", newline="", encoding="utf-8") as f:
        rows = list(csv.DictReader(f))
    return rows


def _header(out: Path) -> list[str]:
    return (out / "summary.csv").read_text(encoding="utf-8").splitlines()[0].split(",")


def _plan(out_dir: Path) -> dict:
    """plan.json without what changes from run to run (the timings)."""
    doc = json.loads((out_dir / "plan.json").read_text(encoding="utf-8"))
    doc.pop("timings")
    return doc


def _tree(folder: Path) -> dict[str, tuple[str, int]]:
    """Every file under ``folder``: relative path -> (sha256, mtime in ns)."""
    return {
        str(p.relative_to(folder)): (hashlib.sha256(p.read_bytes()).hexdigest(), p.stat().st_mtime_ns)
        for p in sorted(folder.rglob("*"))
        if p.is_file()
    }


def _expected_files(plan: dict) -> set[str]:
    names = {"plan.json", "report.html", "oriented.glb", "levels.png", "normals.png"}
    for s in plan["stories"]:
        i = s["index"]
        names |= {f"drafting-{i}.{e}" for e in ("svg", "png", "pdf", "dxf")}
        names |= {f"pen-and-ink-{i}.{e}" for e in ("svg", "png", "pdf")}
        names |= {f"story-{i}.glb", f"flat-walls-{i}.glb", f"wall-segments-{i}.png"}
    return names


def _by_scan(rows: list[dict]) -> dict[str, dict]:
    """Summary rows by room directory (``r0``, ...), the bad file by its name."""
    return {Path(r["scan"]).parent.name if Path(r["scan"]).name != BAD else BAD: r for r in rows}


# --------------------------------------------------------------------------------------------
# One process


def test_summary_matches_each_scans_plan(batch1, scans):
    code, out, printed = batch1
    assert code == 1  # one scan failed, the others were done
    assert _header(out) == list(SUMMARY_COLUMNS)
    for col in ("scan", "stories", "walls", "rooms", "area_m2", "time_s", "status"):
        assert col in SUMMARY_COLUMNS
    rows = _csv(out)
    doc = json.loads((out / "summary.json").read_text(encoding="utf-8"))
    assert printed == doc  # --json prints what summary.json holds
    assert (doc["scans"], doc["ok"], doc["failed"], doc["interrupted"]) == (4, 3, 1, False)
    assert doc["columns"] == list(SUMMARY_COLUMNS) and doc["workers"] == 1 and doc["scheduler"] is None
    # input order (sorted paths), the same rows in both files
    assert [r["scan"] for r in rows] == sorted(r["scan"] for r in rows)
    assert [r["scan"] for r in rows] == [r["scan"] for r in doc["rows"]]
    assert set(_by_scan(rows)) == {BAD, *(name for name, _, _ in ROOMS)}

    for (name, row), jrow in zip(_by_scan(rows).items(), doc["rows"]):
        if name == BAD:
            continue
        assert row["status"] == jrow["status"] == "ok" and row["error"] == jrow["error"] == ""
        folder = Path(row["output"])
        assert folder == out / f"{name}-scan" and folder.is_dir()
        plan = _plan(folder)
        rooms = plan.get("rooms") or []
        assert int(row["stories"]) == jrow["stories"] == len(plan["stories"]) >= 1
        assert int(row["walls"]) == jrow["walls"] == len(plan["walls"]) >= 4
        assert int(row["rooms"]) == jrow["rooms"] == len(rooms) >= 1
        area = sum(r["area"] for r in rooms)
        assert float(row["area_m2"]) == pytest.approx(area, abs=2e-3) and jrow["area_m2"] == pytest.approx(area, abs=2e-3)
        assert area > 5.0
        assert int(row["faces"]) == jrow["faces"] == plan["input"]["faces"]
        assert float(row["time_s"]) > 0 and jrow["time_s"] > 0
        # the annotations beside the scan were used
        assert jrow["annotations"] == str(scans / name / "annotations.json")
        assert len(plan["annotations"]) > 0
        # the directory is complete, with nothing half-written in it
        names = {p.name for p in folder.iterdir()}
        assert _expected_files(plan) <= names, _expected_files(plan) - names
        assert [n for n in names if n.startswith(".")] == [".meshplan"]  # only the ownership stamp
        assert "<svg" in (folder / "report.html").read_text(encoding="utf-8")
    assert not [p for p in out.iterdir() if p.name.startswith(".")], "a staging directory was left behind"


def test_bad_scan_is_reported_and_skipped(batch1):
    _, out, _ = batch1
    row = _by_scan(_csv(out))[BAD]
    jrow = next(r for r in json.loads((out / "summary.json").read_text())["rows"] if r["scan"] == row["scan"])
    assert row["status"] == jrow["status"] == "failed"
    error = row["error"]
    assert error == jrow["error"] and "\n" not in error and len(error) <= 400
    assert BAD in error and "ply" in error.lower()  # which file, read as what
    assert "; " in error  # the problem; what to do
    assert "traceback" not in jrow  # a reported error, not a bug
    for col in ("stories", "walls", "rooms", "area_m2", "faces"):
        assert row[col] == "" and jrow[col] is None
    assert not Path(row["output"]).exists()  # nothing written for it


def test_rerun_refuses_existing_directories_and_keeps_them(batch1, scans, tmp_path, capsys):
    _, first, _ = batch1
    out = tmp_path / "out"
    shutil.copytree(first, out)
    before = _tree(out)
    capsys.readouterr()
    assert main(["batch", str(scans), "-o", str(out), "--quiet"]) == 1
    err = capsys.readouterr().err
    rows = _by_scan(_csv(out))
    for name, _, _ in ROOMS:
        row = rows[name]
        assert row["status"] == "failed"
        assert "already exists" in row["error"] and "--force" in row["error"]
        assert f"{name}-scan" in err  # --quiet still names every failed scan
    assert rows[BAD]["status"] == "failed"
    # every scan's previous result is untouched (only the summary describes the new run)
    after = _tree(out)
    for f in ("summary.csv", "summary.json"):
        before.pop(f), after.pop(f)
    assert after == before

    # --force redoes the scans given (here two, by a glob: the same names as in the whole
    # batch, as two 'scan.obj' are told apart by their directories) and leaves the others alone
    assert main(["batch", str(scans / "r[01]" / "scan.obj"), "-o", str(out), "--force", "--quiet"]) == 0
    assert capsys.readouterr().err == ""
    assert [(r["status"], Path(r["output"]).name) for r in _csv(out)] == [("ok", "r0-scan"), ("ok", "r1-scan")]
    redone = _tree(out)
    for name in ("r0-scan", "r1-scan"):
        assert redone[f"{name}/plan.json"][1] != before[f"{name}/plan.json"][1]
        assert _plan(out / name) == _plan(first / name)
    assert {k: v for k, v in redone.items() if k.startswith("r2-scan/")} == {k: v for k, v in before.items() if k.startswith("r2-scan/")}


def test_glob_input(batch1, scans, tmp_path, capsys):
    _, first, _ = batch1
    out = tmp_path / "out"
    capsys.readouterr()
    # '**' reaches the rooms' directories; only .obj scans match, so the bad .ply is not taken
    assert main(["batch", str(scans / "**" / "*.obj"), "-o", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    rows = _csv(out)
    obj_rooms = [name for name, _, fmt in ROOMS if fmt == "obj"]
    assert [Path(r["scan"]).parent.name for r in rows] == obj_rooms
    assert all(r["status"] == "ok" for r in rows)
    for name in obj_rooms:
        assert _plan(out / f"{name}-scan") == _plan(first / f"{name}-scan")
    # a pattern that matches nothing is a usage error
    assert main(["batch", str(scans / "*.stl"), "-o", str(tmp_path / "none")]) == 2
    assert "matches no file" in capsys.readouterr().err


def test_usage_errors_are_one_line_with_exit_status_2(scans, tmp_path, capsys, monkeypatch):
    empty = tmp_path / "empty"
    empty.mkdir()
    a_file = tmp_path / "file.txt"
    a_file.write_text("x")
    cases = [
        (["batch", str(empty), "-o", str(tmp_path / "o1")], "no scan files"),
        (["batch", str(tmp_path / "missing"), "-o", str(tmp_path / "o2")], "no such directory or file"),
        (["batch", str(scans), "-o", str(a_file)], "not a directory"),
        (["batch", str(scans), "-o", str(tmp_path / "o3"), "--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "cannot be combined"),
        (["batch", str(scans), "-o", str(tmp_path / "o4"), "--set", "slices=-3"], "slices"),
    ]
    for argv, words in cases:
        capsys.readouterr()
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.startswith("error: ") and "\n" not in err and words in err and "; " in err, err
    # without dask.distributed, --scheduler says how to install it
    monkeypatch.setitem(sys.modules, "distributed", None)
    assert main(["batch", str(scans), "-o", str(tmp_path / "o5"), "--scheduler", "tcp://127.0.0.1:1"]) == 2
    err = capsys.readouterr().err
    assert "pip install" in err and "meshplan[dask]" in err
    # nothing was written by a batch refused before it started
    assert not any((tmp_path / f"o{i}").exists() for i in (1, 2, 3, 4, 5))


def test_progress_bar_and_summary_table_on_a_terminal(scans, tmp_path, monkeypatch):
    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    term = Terminal()
    monkeypatch.setattr(sys, "stderr", term)
    monkeypatch.setenv("COLUMNS", "200")
    assert main(["batch", str(scans / "r1" / "scan.obj"), str(scans / BAD), "-o", str(tmp_path / "out")]) == 1
    text = term.getvalue()
    assert "Scans" in text and "2/2" in text  # the overall bar
    assert "ok" in text and "failed" in text and f"{BAD}: " in text  # a line per scan, with the error
    assert "Batch: 2 scans" in text and "1 ok, 1 failed" in text  # the summary table
    assert str(tmp_path / "out") in text and "summary.csv" in text


# --------------------------------------------------------------------------------------------
# In parallel: the same results


def test_two_workers_give_the_same_plans(batch1, scans, tmp_path):
    _, first, _ = batch1
    out = tmp_path / "out"
    assert main(["batch", str(scans), "-o", str(out), "--workers", "2", "--quiet"]) == 1
    doc = json.loads((out / "summary.json").read_text())
    assert doc["workers"] == 2
    _same_as_one_process(first, out)


def test_dask_scheduler(batch1, scans, tmp_path):
    distributed = pytest.importorskip("distributed", reason="--scheduler needs dask.distributed (the dask extra)")
    _, first, _ = batch1
    out = tmp_path / "out"
    # one in-process worker thread: light, and it sees this file system at the same paths
    with distributed.LocalCluster(
        n_workers=1, threads_per_worker=1, processes=False, dashboard_address=None, protocol="tcp://", host="127.0.0.1"
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://")
        assert main(["batch", str(scans), "-o", str(out), "--scheduler", address, "--quiet"]) == 1
    doc = json.loads((out / "summary.json").read_text())
    assert doc["scheduler"] == address and doc["workers"] == 0
    _same_as_one_process(first, out)


def _same_as_one_process(first: Path, out: Path) -> None:
    """The summary (but the times) and every plan.json (but the timings) equal the one-process run's."""

    def strip(rows: list[dict]) -> list[dict]:
        return [{k: v for k, v in r.items() if k not in ("time_s", "cpu_s", "output")} for r in rows]

    one = json.loads((first / "summary.json").read_text())["rows"]
    this = json.loads((out / "summary.json").read_text())["rows"]
    assert strip(this) == strip(one)
    assert [Path(r["output"]).name for r in this] == [Path(r["output"]).name for r in one]
    for r in this:
        if r["status"] == "ok":
            name = Path(r["output"]).name
            assert {p.name for p in (out / name).iterdir()} == {p.name for p in (first / name).iterdir()}
            assert _plan(out / name) == _plan(first / name)


def test_exclude_patterns_and_annotation_pattern(scans, tmp_path, capsys):
    """``--exclude`` drops files that only look like scans (the bad .ply here, the HoloLens 2
    ``*.su_planes.ply`` sidecars in real exports); ``--annotations`` names each scan's
    annotations by a pattern, and options of ``run`` (``--slices``, ``--scale``) reach every scan."""
    from meshplan.batch import find_annotations, find_scans

    assert [p.name for p in find_scans(scans, skip=["*.ply"])] == ["scan.obj", "scan.obj"]
    assert [p.parent.name for p in find_scans(scans, skip=["*/r1/*"])] == ["scans", "r0", "r2"]
    assert find_scans(scans / BAD, skip=[BAD]) == []
    r0 = scans / "r0" / "scan.obj"
    assert find_annotations(r0) == scans / "r0" / "annotations.json"
    assert find_annotations(r0, "{stem}-sensors.json") is None
    assert find_annotations(r0, "../r1/annotations.json") == scans / "r0" / ".." / "r1" / "annotations.json"

    out = tmp_path / "out"
    capsys.readouterr()
    code = main(["batch", str(scans), "-o", str(out), "--quiet", "-x", BAD, "--exclude", "*/r2/*",
                 "--slices", "7", "--scale", "50", "-a", "{stem}-missing.json"])
    assert code == 0, capsys.readouterr().err
    rows = _csv(out)
    assert [Path(r["scan"]).parent.name for r in rows] == ["r0", "r1"] and all(r["status"] == "ok" for r in rows)
    for r in rows:
        plan = json.loads((Path(r["output"]) / "plan.json").read_text())
        assert plan["parameters"]["plan"]["slices"] == 7 and plan["parameters"]["render"]["scale"] == 50
        assert plan["annotations"] == [] or not plan["annotations"]  # the pattern names no file
    # everything excluded: a usage error in one line
    assert main(["batch", str(scans), "-o", str(tmp_path / "none"), "-x", "*"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("error: ") and len(err.splitlines()) == 1


def test_run_and_batch_map_the_same_scan_options(monkeypatch, tmp_path):
    """Every option of ``run`` that applies to each scan reaches :func:`meshplan.run` from
    ``batch`` too, under the same keyword (one declaration, one mapping: cli._SCAN_OPTIONS)."""
    from typer.testing import CliRunner

    import meshplan.api
    import meshplan.batch
    from meshplan.cli import app

    class Stop(Exception):
        pass

    seen: dict[str, dict] = {}

    def fake_run(scan, **kw):
        seen["run"] = {k: v for k, v in kw.items() if k not in ("annotations", "output", "force", "progress")}
        raise Stop

    def fake_batch(jobs, output, **kw):
        seen["batch"] = {k: v for k, v in kw.items() if k not in ("workers", "scheduler", "force", "progress")}
        raise Stop

    monkeypatch.setattr(meshplan.api, "run", fake_run)
    monkeypatch.setattr(meshplan.batch, "run_batch", fake_batch)
    scan = tmp_path / "a.obj"
    scan.write_text("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    given = [
        "--units", "cm", "--gravity", "bbox", "--slices", "50", "--box-length", "0.5", "--wall-directions", "all",
        "--north-deg", "30", "--site-lat", "48.1", "--ifc", "--imperial", "--set", "dpi=90",
    ]  # fmt: skip
    want = {
        "units": "cm", "gravity_method": "bbox", "slices": 50, "box_length_m": 0.5, "wall_directions": "all",
        "north_deg": 30.0, "site_lat_deg": 48.1, "ifc": True, "imperial": True, "dpi": 90,
    }  # fmt: skip
    runner = CliRunner()
    r = runner.invoke(app, ["run", str(scan), "-o", str(tmp_path / "out"), *given])
    assert isinstance(r.exception, Stop), r.output
    b = runner.invoke(app, ["batch", str(scan), "-o", str(tmp_path / "batch"), *given])
    assert isinstance(b.exception, Stop), b.output
    assert seen["run"] == want
    assert seen["batch"] == want
