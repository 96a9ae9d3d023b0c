"""Reliability: every bad input gets a clear one-line error and leaves nothing behind; output is
atomic; results are reproducible."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

from meshplan.cli import main
from meshplan.export.synth import write_synthetic
from meshplan.synthetic import SynthParams, generate

from conftest import box_room


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """A small synthetic room scan (PLY) with its annotations."""
    d = tmp_path_factory.mktemp("good")
    scan = generate(SynthParams(preset="room", seed=11, triangle_size_m=(0.12, 0.2)))
    return write_synthetic(scan, d / "room", "ply")


def _ply(path: Path, vertices, faces) -> Path:
    path.write_bytes(trimesh.Trimesh(vertices, faces, process=False).export(file_type="ply"))
    return path


def _cases(tmp: Path, good: Path) -> list[tuple[str, list[str], str]]:
    """(name, argv, expected words in the message)."""
    ok_bytes = good.read_bytes()
    v, f = box_room(4.0, 3.0, 2.5, cell=0.25)
    cases = []

    def file(name: str, data: bytes) -> str:
        p = tmp / name
        p.write_bytes(data)
        return str(p)

    cases.append(("missing file", [str(tmp / "nope.obj")], "file not found"))
    (tmp / "adir.obj").mkdir()
    cases.append(("directory", [str(tmp / "adir.obj")], "is a directory"))
    cases.append(("unknown extension", [file("scan.xyz", b"1 2 3\n")], "unknown mesh format"))
    cases.append(("empty file", [file("empty.ply", b"")], "empty"))
    rng = np.random.default_rng(0)
    for ext in ("ply", "obj", "glb", "stl", "off"):
        cases.append((f"garbage .{ext}", [file(f"garbage.{ext}", rng.bytes(4096))], ""))
    cases.append(("truncated PLY", [file("trunc.ply", ok_bytes[: len(ok_bytes) // 2])], "cannot be read as PLY"))
    obj = trimesh.Trimesh(v, f, process=False).export(file_type="obj").encode()
    cases.append(("truncated OBJ", [file("trunc.obj", obj[: len(obj) // 3 + 5])], "cut short"))
    head, body = ok_bytes.split(b"end_header", 1)
    n_faces = int([ln for ln in head.decode().splitlines() if ln.startswith("element face")][0].split()[2])
    lying = head.replace(f"element face {n_faces}".encode(), f"element face {n_faces * 2}".encode()) + b"end_header" + body
    cases.append(("PLY with a lying header", [file("lying.ply", lying)], "cannot be read as PLY"))
    huge = head.replace(f"element face {n_faces}".encode(), b"element face 90000000000") + b"end_header" + body
    cases.append(("too large for memory", [file("huge.ply", huge)], "GB of memory"))
    points = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    cases.append(("point cloud", [file("points.ply", points)], "no triangles"))
    cases.append(("single triangle", [str(_ply(tmp / "tri.ply", [[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 2, 1]]))], ""))
    nan = np.full_like(v, np.nan)
    cases.append(("NaN coordinates", [file("nan.obj", "".join(f"v {a} {b} {c}\n" for a, b, c in nan).encode() + b"f 1 2 3\nf 2 3 4\n")], "NaN or infinite"))
    inf = "v inf 0 0\nv 0 inf 0\nv 0 0 inf\nf 1 2 3\n"
    cases.append(("inf coordinates", [file("inf.obj", inf.encode())], "NaN or infinite"))
    cases.append(("all degenerate", [file("degenerate.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n")], "degenerate"))
    cases.append(("millimetres read as metres", [str(_ply(tmp / "mm.ply", v * 1000.0, f))], "--units mm"))
    wall = [[0, 0, 0], [4, 0, 0], [4, 2.5, 0], [0, 2.5, 0]]
    cases.append(("only one wall", [str(_ply(tmp / "wall.ply", wall, [[0, 1, 2], [0, 2, 3]]))], ""))
    floorless = generate(SynthParams(preset="room", seed=2, triangle_size_m=(0.12, 0.2)))
    keep = np.flatnonzero(floorless.face_kinds != 0)
    cases.append(("no floor", [str(_ply(tmp / "nofloor.ply", floorless.mesh.vertices, floorless.mesh.faces[keep]))], "no floor"))
    ann = good.parent / "annotations.json"
    for name, text, words in (
        ("annotations: malformed JSON", "{oops", "not valid JSON"),
        ("annotations: missing field", json.dumps({"annotations": [{"label": "S1", "kind": "sensor"}]}), "has no 'position'"),
        ("annotations: wrong kind", json.dumps({"annotations": [{"label": "S1", "kind": "lamp", "position": [0, 0, 0]}]}), "unknown kind"),
        ("annotations: NaN position", '{"annotations": [{"label": "S1", "kind": "sensor", "position": [NaN, 0, 0]}]}', "NaN or infinite"),
    ):
        cases.append((name, [str(good), "--annotations", file(name.split(": ")[1].replace(" ", "_") + ".json", text.encode())], words))
    assert ann.exists()
    return cases


def test_bad_input_matrix(tmp_path, good, capsys):
    out = tmp_path / "out"
    for name, argv, words in _cases(tmp_path, good):
        code = main(["run", *argv, "-o", str(out)])
        err = capsys.readouterr().err.strip()
        assert code == 2, (name, err)
        lines = err.splitlines()
        assert len(lines) == 1 and lines[0].startswith("error: "), (name, err)
        assert "Traceback" not in err
        assert "; " in lines[0], (name, err)  # the problem; then what to do
        assert words.lower() in lines[0].lower(), (name, err)
        assert not out.exists(), name  # nothing half-written
        assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")], name


def test_no_ceiling_succeeds_with_a_warning(tmp_path, capsys):
    scan = generate(SynthParams(preset="room", seed=3, triangle_size_m=(0.12, 0.2)))
    keep = np.flatnonzero(scan.face_kinds != 1)
    path = _ply(tmp_path / "noceiling.ply", scan.mesh.vertices, scan.mesh.faces[keep])
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--json", "--default-ceiling-height", "2.4"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert any("no ceiling" in w and "2.40 m" in w for w in summary["warnings"])
    story = summary["stories"][0]
    assert not story["ceiling_found"] and story["height"] == pytest.approx(2.4)


def test_output_directory_rules(tmp_path, good, capsys):
    out = tmp_path / "out"
    assert main(["run", str(good), "-o", str(out), "--quiet"]) == 0
    before = (out / "plan.json").read_bytes()
    assert main(["run", str(good), "-o", str(out), "--quiet"]) == 2
    assert "already exists" in capsys.readouterr().err
    assert (out / "plan.json").read_bytes() == before  # untouched
    assert main(["run", str(good), "-o", str(out), "--quiet", "--force", "--slices", "10"]) == 0
    assert json.loads((out / "plan.json").read_text())["parameters"]["plan"]["slices"] == 10
    locked = tmp_path / "locked"
    locked.mkdir()
    os.chmod(locked, 0o500)
    try:
        if os.access(locked, os.W_OK):
            pytest.skip("running as a user who can write anywhere")
        assert main(["run", str(good), "-o", str(locked / "out")]) == 2
        assert "cannot write" in capsys.readouterr().err
    finally:
        os.chmod(locked, 0o700)


def test_errors_in_a_real_process_have_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "meshplan", "run", str(tmp_path / "missing.ply")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"error: {tmp_path / 'missing.ply'}: file not found; check the path of the scan"]
    proc = subprocess.run([sys.executable, "-m", "meshplan", "run", "x.ply", "--slices", "many"], capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


def _complete(out: Path) -> bool:
    names = {p.name for p in out.iterdir()}
    needed = {"plan.json", "oriented.glb", "story-0.glb", "drafting-0.png", "pen-and-ink-0.pdf", "report.html"}
    if not needed <= names:
        return False
    json.loads((out / "plan.json").read_text())
    return True


def test_a_killed_run_leaves_the_old_result_or_the_new_one(tmp_path, good):
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "meshplan", "run", str(good), "-o", str(out), "--quiet", "--force"]
    subprocess.run(cmd, check=True)
    old = json.loads((out / "plan.json").read_text())
    t0 = time.perf_counter()
    subprocess.run(cmd + ["--slices", "37"], check=True)
    duration = time.perf_counter() - t0
    outcomes = set()
    for frac in (0.4, 0.75, 0.88, 0.95, 0.99):
        subprocess.run(cmd, check=True)  # the "previous result"
        proc = subprocess.Popen(cmd + ["--slices", "37"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(duration * frac)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        assert out.is_dir()
        assert _complete(out)
        slices = json.loads((out / "plan.json").read_text())["parameters"]["plan"]["slices"]
        assert slices in (old["parameters"]["plan"]["slices"], 37)
        outcomes.add(slices)
    # the next run cleans up what the killed ones left beside the output
    subprocess.run(cmd, check=True)
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".out.meshplan")] == []


def _strip_timings(path: Path) -> dict:
    doc = json.loads(path.read_text())
    doc.pop("timings")
    return doc


def test_runs_are_deterministic(tmp_path, good):
    a, b = tmp_path / "a", tmp_path / "b"
    for out in (a, b):
        assert main(["run", str(good), "-o", str(out), "--quiet", "--ifc"]) == 0
    ta = (a / "plan.json").read_text()
    tb = (b / "plan.json").read_text()
    assert _strip_timings(a / "plan.json") == _strip_timings(b / "plan.json")
    # byte-identical apart from the timings block, which is last
    assert ta.split('"timings"')[0] == tb.split('"timings"')[0]
    for name in ("drafting-0.png", "drafting-0.svg", "drafting-0.pdf", "drafting-0.dxf", "pen-and-ink-0.png", "pen-and-ink-0.svg", "pen-and-ink-0.pdf", "oriented.glb", "story-0.glb", "model.ifc", "levels.png", "normals.png", "wall-segments-0.png"):
        assert (a / name).read_bytes() == (b / name).read_bytes(), name
