"""Reliability (issue 6): every bad input gets a clear one-line error and leaves nothing behind;
output appears atomically, even when the process is killed while writing; results are
reproducible byte for byte."""

from __future__ import annotations

import errno
import hashlib
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import trimesh

import meshplan.export as export
from conftest import box_room
from meshplan.cli import main
from meshplan.export.synth import write_synthetic
from meshplan.io import atomic
from meshplan.synthetic import SynthParams, generate

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")

#: (name, argv without the output, (words of the problem, words of what to do))
Case = tuple[str, list[str], tuple[str, str]]


@pytest.fixture(scope="module")
def good(tmp_path_factory) -> Path:
    """A small synthetic room scan (PLY) with its annotations."""
    d = tmp_path_factory.mktemp("good")
    scan = generate(SynthParams(preset="room", seed=11, triangle_size_m=(0.12, 0.2)))
    return write_synthetic(scan, d / "room", "ply")


def _ply(path: Path, vertices, faces) -> Path:
    path.write_bytes(trimesh.Trimesh(vertices, faces, process=False).export(file_type="ply"))
    return path


def _sparse(path: Path, head: bytes, size: int) -> str:
    """A file of ``size`` bytes starting with ``head``; the rest is a hole taking no disk space."""
    with open(path, "wb") as fh:
        fh.write(head)
        fh.truncate(size)
    return str(path)


def _tree(directory: Path) -> dict[str, str]:
    """Every file and directory below ``directory``: relative name -> SHA-256 (or "dir")."""
    out = {}
    for p in sorted(directory.rglob("*")):
        out[str(p.relative_to(directory))] = "dir" if p.is_dir() else hashlib.sha256(p.read_bytes()).hexdigest()
    return out


def _cases(tmp: Path, good: Path) -> list[Case]:
    """The bad-input matrix of issue 6 (files are written into ``tmp``)."""
    ok_bytes = good.read_bytes()
    v, f = box_room(4.0, 3.0, 2.5, cell=0.25)
    cases: list[Case] = []

    def file(name: str, data: bytes) -> str:
        p = tmp / name
        p.write_bytes(data)
        return str(p)

    cases.append(("missing file", [str(tmp / "nope.obj")], ("file not found", "check the path")))
    (tmp / "adir.obj").mkdir()
    cases.append(("directory", [str(tmp / "adir.obj")], ("is a directory, not a mesh file", "give the path of an OBJ")))
    cases.append(("unknown extension", [file("scan.abc", b"1 2 3\n")], ("unknown mesh format '.abc'", "convert the scan to OBJ")))
    cases.append(("empty file", [file("empty.ply", b"")], ("the file is empty", "export the scan again")))
    rng = np.random.default_rng(0)
    garbage = {
        "ply": ("cannot be read as PLY", "complete, uncorrupted mesh export"),
        "obj": ("holds binary data, not OBJ text", "check that the file really is an OBJ export"),
        "off": ("holds binary data, not OFF text", "check that the file really is an OFF export"),
        "glb": ("cannot be read as GLB", "complete, uncorrupted mesh export"),
        "gltf": ("not a glTF file: not valid JSON", "check that the file is a glTF export"),
        "stl": ("faces but the file is only 4,096 bytes", "re-export the scan"),
    }
    for ext, words in garbage.items():
        cases.append((f"binary garbage .{ext}", [file(f"garbage.{ext}", rng.bytes(4096))], words))
    cases.append(("truncated PLY", [file("trunc.ply", ok_bytes[: len(ok_bytes) // 2])], ("is truncated: header says", "re-export the scan")))
    obj = trimesh.Trimesh(v, f, process=False).export(file_type="obj").encode()
    cases.append(("truncated OBJ", [file("trunc.obj", obj[: len(obj) // 3 + 5])], ("it was cut short", "export or copy the scan again")))
    head, body = ok_bytes.split(b"end_header", 1)
    n_faces = int([ln for ln in head.decode().splitlines() if ln.startswith("element face")][0].split()[2])
    lying = head.replace(f"element face {n_faces}".encode(), f"element face {n_faces * 2}".encode()) + b"end_header" + body
    cases.append(("PLY with a lying header", [file("lying.ply", lying)], (f"is truncated: header says {2 * n_faces:,} faces, file holds {n_faces:,}", "re-export the scan")))
    points = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n0 0 0\n1 0 0\n0 1 0\n"
    cases.append(("point cloud", [file("points.ply", points)], ("holds points but no triangles", "mesh the point cloud first")))
    cases.append(("single triangle", [str(_ply(tmp / "tri.ply", [[0, 0, 0], [1, 0, 0], [0, 0, 1]], [[0, 2, 1]]))], ("the scan holds no room: all its 1 faces are parallel", "scan the whole room")))
    nan = np.full_like(v, np.nan)
    cases.append(("NaN coordinates", [file("nan.obj", "".join(f"v {a} {b} {c}\n" for a, b, c in nan).encode() + b"f 1 2 3\nf 2 3 4\n")], ("2 with NaN or infinite coordinates", "export the scan again")))
    cases.append(("inf coordinates", [file("inf.obj", b"v inf 0 0\nv 0 inf 0\nv 0 0 inf\nf 1 2 3\n")], ("1 with NaN or infinite coordinates", "export the scan again")))
    cases.append(("all degenerate faces", [file("degenerate.obj", b"v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3\nf 2 3 4\n")], ("none of its 2 faces is usable (0 with NaN or infinite coordinates, 2 degenerate", "export the scan again")))
    cases.append(("millimetres read as metres", [str(_ply(tmp / "mm.ply", v * 1000.0, f))], ("an implausible story height", "pass --units mm")))
    cases.append(("centimetres read as metres", [str(_ply(tmp / "cm.ply", v * 100.0, f))], ("implausible scale", "pass --units cm")))
    tri = v[f]
    wall = np.abs(tri[:, :, 2]).max(axis=1) < 1e-9  # the wall z = 0 of the box, finely tessellated
    cases.append(("only one wall", [str(_ply(tmp / "wall.ply", v, f[wall]))], ("the scan holds no room: all its 320 faces are parallel", "scan the whole room")))
    floorless = generate(SynthParams(preset="room", seed=2, triangle_size_m=(0.12, 0.2)))
    keep = np.flatnonzero(floorless.face_kinds != 0)
    cases.append(("no floor", [str(_ply(tmp / "nofloor.ply", floorless.mesh.vertices, floorless.mesh.faces[keep]))], ("no floor found", "make sure the scan includes the floor")))
    for name, text, words in (
        ("annotations: malformed JSON", "{oops", ("not valid JSON (line 1, column 2", "fix the JSON syntax")),
        ("annotations: missing field", json.dumps({"annotations": [{"label": "S1", "kind": "sensor"}]}), ("annotation 1 has no 'position'", "add 'position' to every annotation")),
        ("annotations: wrong kind", json.dumps({"annotations": [{"label": "S1", "kind": "lamp", "position": [0, 0, 0]}]}), ('unknown kind "lamp"', "use one of sensor, thermostat")),
        ("annotations: wrong type", json.dumps({"annotations": [{"label": "S1", "kind": "sensor", "position": "here"}]}), ("'position' must be a list of three numbers", "fix the annotation file")),
        ("annotations: NaN position", '{"annotations": [{"label": "S1", "kind": "sensor", "position": [NaN, 0, 0]}]}', ("'position' has a NaN or infinite coordinate", "fix the annotation file")),
        ("annotations: missing file", None, ("annotation file not found", "check the path given to --annotations")),
    ):
        path = tmp / (name.split(": ")[1].replace(" ", "_") + ".json")
        if text is not None:
            path.write_text(text)
        cases.append((name, [str(good), "--annotations", str(path)], words))
    # limits: sizes declared by headers (or, for OBJ, implied by the file size) that cannot fit;
    # the files are sparse, so they take no disk space
    ply_head = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
    ply_head += b"element face 4000000000\nproperty list uchar int vertex_indices\nend_header\n"
    big = ("4,000,000,000 faces would need about 4000.0 GB of memory", "pass --max-faces 4000000000 to try anyway")
    cases.append(("too large for memory: PLY", [_sparse(tmp / "huge.ply", ply_head, len(ply_head) + 36 + 13 * 4_000_000_000)], big))
    cases.append(("too large for memory: STL", [_sparse(tmp / "huge.stl", bytes(80) + (2_000_000_000).to_bytes(4, "little"), 84 + 50 * 2_000_000_000)], ("2,000,000,000 faces would need about 2000.0 GB", "--max-faces 2000000000")))
    cases.append(("too large for memory: OBJ", [_sparse(tmp / "huge.obj", b"v 0 0 0\n", 100 * 10**9)], ("5,000,000,000 faces would need about 5000.0 GB", "--max-faces 5000000000")))
    cases.append(("more faces than --max-faces", [str(good), "--max-faces", "100"], ("more than --max-faces 100 (it would need about 0.0 GB", "raise --max-faces to")))
    return cases


def _check_message(name: str, code: int, err: str, words: tuple[str, str], status: int = 2) -> None:
    """One line, ``error: <problem>; <what to do>``, naming the problem and what to do."""
    assert code == status, (name, code, err)
    assert "Traceback" not in err, (name, err)
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), (name, err)
    assert lines[0].count("; ") == 1, (name, err)
    problem, hint = lines[0][len("error: "):].split("; ")
    assert words[0].lower() in problem.lower(), (name, "problem", err)
    assert words[1].lower() in hint.lower(), (name, "what to do", err)


from meshplan.io.atomic import KIND_PLANS, write_stamp  # noqa: E402


def _previous_result(path: Path) -> dict[str, str]:
    """A stand-in for the result of an earlier run (a failing run must not touch it)."""
    path.mkdir(parents=True)
    (path / "plan.json").write_text('{"previous": true}\n')
    (path / "drafting-0.png").write_bytes(b"\x89PNG previous")
    write_stamp(path, KIND_PLANS)  # meshplan's own, so --force may replace it
    return _tree(path)


def test_bad_input_matrix(tmp_path, good, capsys):
    """Exit status 2, one line naming the problem and what to do, no traceback; no output
    directory (nor hidden temporary one, nor parent) left behind, a previous result untouched."""
    inputs, outs = tmp_path / "in", tmp_path / "outs"
    inputs.mkdir()
    previous = outs / "previous"
    before = _previous_result(previous)
    listing = _tree(outs)
    cases = _cases(inputs, good)
    assert len(cases) == 32 and all(all(words) for _, _, words in cases)  # every message is checked
    for name, argv, words in cases:
        for out in (["-o", str(outs / "fresh" / "deeper" / "out")], ["-o", str(previous), "--force"]):
            code = main(["run", *argv, *out])
            _check_message(name, code, capsys.readouterr().err, words)
            assert _tree(outs) == listing, (name, out)  # nothing created, nothing changed
    assert _tree(previous) == before


def test_output_location_errors(tmp_path, good, capsys):
    """Unwritable output locations (for root too) and an existing output directory."""
    a_file = tmp_path / "a-file"
    a_file.write_text("not a directory")
    previous = tmp_path / "previous"
    before = _previous_result(previous)
    cases = [
        ("output under a regular file", ["-o", str(a_file / "out")], ("a-file is a file, not a directory", "choose another output path with -o")),
        ("output is a regular file", ["-o", str(a_file)], ("exists and is not a directory", "choose another output path with -o")),
        ("existing output directory", ["-o", str(previous)], ("output directory already exists", "pass --force to replace it")),
    ]
    if Path("/proc/self").is_dir():  # nobody, not even root, can create a directory in /proc
        cases.append(("output in /proc", ["-o", "/proc/meshplan-test-out"], ("cannot write in /proc", "choose a writable output directory with -o")))
    listing = _tree(tmp_path)
    for name, out, words in cases:
        code = main(["run", str(good), *out])
        _check_message(name, code, capsys.readouterr().err, words)
        assert _tree(tmp_path) == listing, name
    assert _tree(previous) == before and a_file.read_text() == "not a directory"
    assert not Path("/proc/meshplan-test-out").exists()


def test_a_directory_without_write_permission_is_refused(tmp_path, good, capsys):
    locked = tmp_path / "locked"
    locked.mkdir()
    os.chmod(locked, 0o500)
    try:
        try:
            (locked / "probe").mkdir()
        except PermissionError:
            pass
        else:
            pytest.skip("this user writes in any directory (root; see test_output_location_errors)")
        code = main(["run", str(good), "-o", str(locked / "out")])
        _check_message("read-only directory", code, capsys.readouterr().err, ("cannot write in", "choose a writable output directory"))
        assert list(locked.iterdir()) == []
    finally:
        os.chmod(locked, 0o700)


def test_no_ceiling_succeeds_with_a_warning(tmp_path, capsys):
    scan = generate(SynthParams(preset="room", seed=3, triangle_size_m=(0.12, 0.2)))
    keep = np.flatnonzero(scan.face_kinds != 1)
    path = _ply(tmp_path / "noceiling.ply", scan.mesh.vertices, scan.mesh.faces[keep])
    assert main(["run", str(path), "-o", str(tmp_path / "out"), "--json", "--default-ceiling-height", "2.4"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    # the warning states the height used, and how to change it
    assert [w for w in summary["warnings"] if "no ceiling" in w] == [
        "no ceiling found; assuming a ceiling 2.40 m above the floor (--default-ceiling-height)"
    ]
    assert "no ceiling found" in captured.err
    story = summary["stories"][0]
    assert not story["ceiling_found"] and story["height"] == pytest.approx(2.4)
    plan = json.loads((tmp_path / "out" / "plan.json").read_text())
    assert any("no ceiling" in w for w in plan["warnings"])


def test_output_directory_rules(tmp_path, good, capsys):
    out = tmp_path / "out"
    assert main(["run", str(good), "-o", str(out), "--quiet"]) == 0
    before = _tree(out)
    code = main(["run", str(good), "-o", str(out), "--quiet"])
    _check_message("existing output", code, capsys.readouterr().err, ("already exists", "pass --force"))
    assert _tree(out) == before  # untouched
    assert main(["run", str(good), "-o", str(out), "--quiet", "--force", "--slices", "10"]) == 0
    assert json.loads((out / "plan.json").read_text())["parameters"]["plan"]["slices"] == 10
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no hidden leftovers


def test_errors_in_a_real_process_have_no_traceback(tmp_path):
    proc = subprocess.run([sys.executable, "-m", "meshplan", "run", str(tmp_path / "missing.ply")], capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [f"error: {tmp_path / 'missing.ply'}: file not found; check the path of the scan"]
    proc = subprocess.run([sys.executable, "-m", "meshplan", "run", "x.ply", "--slices", "many"], capture_output=True, text=True)
    assert proc.returncode == 2 and len(proc.stderr.strip().splitlines()) == 1 and "Traceback" not in proc.stderr


# --------------------------------------------------------------------------------------------
# failures while drawing or writing


#: Stand-ins for the drawings (rendering is not what these tests are about): the files before and
#: after drafting-0.png are written, then the writing fails.
RENDERED = {"drafting-0.dxf": b"0\nSECTION\n" * 1000, "drafting-0.png": b"\x89PNG" * 1000, "story-0.glb": b"glTF" * 1000}


@pytest.mark.parametrize("failure", ["render bug", "render memory", "disk full", "publish", "interrupt"])
def test_a_failure_while_drawing_or_writing_leaves_nothing(tmp_path, good, capsys, monkeypatch, failure):
    """A failure at any point after the computation leaves neither an output directory (nor its
    new parents, nor a hidden temporary directory) nor a changed previous result."""
    expected = {
        "render bug": (1, ("internal error (RuntimeError: boom)", "please report this bug in meshplan")),
        "render memory": (2, ("ran out of memory", "decimate the scan")),
        "disk full": (2, ("writing drafting-0.png failed (No space left on device) and nothing was changed", "free some space")),
        "publish": (2, ("failed (Input/output error) and nothing was changed", "choose another output directory")),
        "interrupt": (130, ("interrupted", "nothing was written")),
    }[failure]

    def render(result, timer=None, pool=None, early=None):
        if failure == "render bug":
            raise RuntimeError("boom")
        if failure == "render memory":
            raise MemoryError()
        return dict(RENDERED)

    real_write = pathlib.Path.write_bytes

    def write_bytes(self, data):
        if atomic._TMP_TAG in str(self.parent) and self.name == "drafting-0.png":  # half-way through the files
            if failure == "disk full":
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(self))
            if failure == "interrupt":
                raise KeyboardInterrupt
        return real_write(self, data)

    def publish(tmp, target, force):
        raise OSError(errno.EIO, os.strerror(errno.EIO))

    monkeypatch.setattr(export, "render_files", render)
    monkeypatch.setattr(pathlib.Path, "write_bytes", write_bytes)
    if failure == "publish":
        monkeypatch.setattr(atomic, "_publish", publish)
    previous = tmp_path / "previous"
    _previous_result(previous)  # the tree listed below holds it
    listing = _tree(tmp_path)
    for out in (["-o", str(tmp_path / "new" / "deeper" / "out")], ["-o", str(previous), "--force"]):
        code = main(["run", str(good), *out, "--quiet"])
        _check_message(failure, code, capsys.readouterr().err, expected[1], status=expected[0])
        assert _tree(tmp_path) == listing, (failure, out)


# --------------------------------------------------------------------------------------------
# killed runs

#: Run in a subprocess: compute two results of the scan argv[1], write the first to argv[2], then
#: fork writers of the second that SIGKILL themselves at their k-th step (half-way through a
#: file, after a file, around every rename and removal), for k = 1, 2, ... until one finishes;
#: after each kill, report what the output directory holds. Forked writers share the computed
#: results, so every step of the writing is killed without recomputing anything.
KILL_AT_EVERY_STEP = r'''
import hashlib, json, os, pathlib, shutil, signal, sys, traceback

import meshplan.export as export
from meshplan.io import atomic
from meshplan.api import run

scan, out = sys.argv[1], pathlib.Path(sys.argv[2])
old, new = run(scan, slices=10), run(scan, slices=37)
rendered = {id(old): export.render_files(old), id(new): export.render_files(new)}
export.render_files = lambda result, timer=None, pool=None, early=None: dict(rendered[id(result)])


def tree(d):
    """name -> digest (plan.json without its timings, or "corrupt"), or None without d."""
    if not d.is_dir():
        return None
    found = {}
    for p in sorted(d.iterdir()):
        data = p.read_bytes()
        if p.name == "plan.json":
            try:
                doc = json.loads(data)
                doc.pop("timings")
                data = json.dumps(doc, sort_keys=True).encode()
            except ValueError:
                data = b"corrupt"
        found[p.name] = hashlib.sha256(data).hexdigest()
    return found


reference = out.parent / "reference"
export.write_results(old, reference / "old")
export.write_results(new, reference / "new")
expected = {"old": tree(reference / "old"), "new": tree(reference / "new")}
shutil.rmtree(reference)
a, b = out.parent / "swap-a", out.parent / "swap-b"
a.mkdir(), b.mkdir()
exchange_supported = atomic._exchange(a, b)
a.rmdir(), b.rmdir()


def state():
    t = tree(out)
    return "none" if t is None else next((k for k, v in expected.items() if t == v), "mixed")


def writer(k, mode):
    """In a forked child: write `new`, killing this process at its k-th step."""
    steps = [0]

    def step():
        steps[0] += 1
        if steps[0] == k:
            os.kill(os.getpid(), signal.SIGKILL)

    def write_bytes(self, data):
        with open(self, "wb") as fh:
            fh.write(data[: len(data) // 2])
            fh.flush()
            step()  # killed half-way through a file
            fh.write(data[len(data) // 2 :])
        step()
        return len(data)

    def wrap(fn):
        def stepped(*args, **kwargs):
            step()
            value = fn(*args, **kwargs)
            step()
            return value
        return stepped

    pathlib.Path.write_bytes = write_bytes
    pathlib.Path.write_text = lambda self, text, encoding=None, errors=None, newline=None: write_bytes(self, text.encode(encoding or "utf-8"))
    os.replace = wrap(os.replace)
    shutil.rmtree = wrap(shutil.rmtree)
    atomic._exchange = wrap(atomic._exchange if mode == "exchange" else (lambda a, b: False))
    export.write_results(new, out, force=True)


report = []
for mode in ("exchange", "two renames", "no previous"):
    for k in range(1, 1000):
        if mode == "no previous":
            shutil.rmtree(out, ignore_errors=True)
        elif state() != "old":
            export.write_results(old, out, force=True)
        pid = os.fork()
        if pid == 0:
            try:
                writer(k, mode)
            except BaseException:
                traceback.print_exc()
                os._exit(3)
            os._exit(0)
        _, status = os.waitpid(pid, 0)
        killed = os.WIFSIGNALED(status) and os.WTERMSIG(status) == signal.SIGKILL
        if not killed and os.waitstatus_to_exitcode(status) != 0:
            sys.exit(f"the writer failed at step {k} ({mode})")
        seen = state()
        atomic.remove_stale(out)  # what the next run does first
        hidden = sorted(p.name for p in out.parent.iterdir() if p.name.startswith("."))
        report.append({"mode": mode, "step": k, "killed": killed, "state": seen, "after_cleanup": state(), "hidden": hidden})
        if not killed:
            break
print(json.dumps({"exchange_supported": exchange_supported, "files": len(expected["new"]), "kills": report}))
'''


def test_a_run_killed_at_any_step_of_writing_leaves_the_old_result_or_the_new_one(tmp_path, good):
    script = tmp_path / "kill.py"
    script.write_text(KILL_AT_EVERY_STEP)
    proc = subprocess.run([sys.executable, str(script), str(good), str(tmp_path / "work" / "out")], capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-3000:]
    found = json.loads(proc.stdout.strip().splitlines()[-1])
    kills = found["kills"]
    for mode in ("exchange", "two renames", "no previous"):
        runs = [r for r in kills if r["mode"] == mode]
        # the last writer ran to the end; every one before was killed, at least twice per file
        assert [r["killed"] for r in runs] == [True] * (len(runs) - 1) + [False], mode
        assert len(runs) > 2 * found["files"], mode
        assert runs[-1]["state"] == "new", mode
        allowed = {"none", "new"} if mode == "no previous" else {"old", "new"}
        for r in runs:
            assert r["after_cleanup"] in allowed, r  # never a mixture, nothing lost
            assert r["hidden"] == [], r  # the next run removes what the killed one left
            if mode == "exchange" and found["exchange_supported"]:
                assert r["state"] in allowed, r  # not even a moment without a result
            else:
                assert r["state"] in allowed | {"none"}, r
        # most kills hit the writing of the files (the old result stays), some the swap (the
        # new one is in place, the old one not yet deleted)
        states = [r["state"] for r in runs if r["killed"]]
        assert states.count("none" if mode == "no previous" else "old") >= 2 * found["files"], mode
        if mode == "exchange":
            assert "new" in states


def _pen_and_ink_complete(path: Path) -> bool:
    data = path.read_bytes()
    return {".png": data.endswith(b"IEND\xaeB`\x82"), ".pdf": data.rstrip().endswith(b"%%EOF"), ".svg": data.rstrip().endswith(b"</svg>")}[path.suffix]


def test_a_run_killed_from_outside_while_writing(tmp_path, good):
    """SIGKILL a real ``meshplan run --force`` as soon as its hidden staging directory holds
    some files: the output is the complete previous result or the complete new one."""
    out = tmp_path / "out"
    assert main(["run", str(good), "-o", str(out), "--quiet"]) == 0
    previous = _tree(out)
    pristine = tmp_path / "pristine"
    shutil.copytree(out, pristine)
    cmd = [sys.executable, "-m", "meshplan", "run", str(good), "-o", str(out), "--quiet", "--force", "--slices", "37"]
    during = []
    for wait_for_files in (1, 6):
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        deadline = time.monotonic() + 300
        killed_while_staging = False
        while proc.poll() is None and time.monotonic() < deadline:
            try:
                staged = [p for p in tmp_path.iterdir() if p.name.startswith(".out" + atomic._TMP_TAG)]
                if staged and len(list(staged[0].iterdir())) >= wait_for_files:
                    proc.send_signal(signal.SIGKILL)
                    killed_while_staging = True
                    break
            except FileNotFoundError:  # renamed into place while we looked
                pass
            time.sleep(0.001)
        if proc.poll() is None and not killed_while_staging:
            proc.kill()
        proc.wait()
        assert proc.returncode in (0, -signal.SIGKILL), proc.stderr.read()
        proc.stderr.close()
        during.append(killed_while_staging and proc.returncode == -signal.SIGKILL)
        now = _tree(out)
        if now != previous:  # the new result, complete: same files, only the slices differ
            assert now.keys() == previous.keys()
            assert json.loads((out / "plan.json").read_text())["parameters"]["plan"]["slices"] == 37
            for name in now:
                if name.startswith("pen-and-ink-"):
                    assert _pen_and_ink_complete(out / name), name
                elif name not in ("plan.json", "report.html"):
                    assert now[name] == previous[name], name
            assert (out / "report.html").read_text().rstrip().endswith("</html>")
        atomic.remove_stale(out)  # what the next run does first
        assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []
        shutil.rmtree(out)
        shutil.copytree(pristine, out)
    print(f"killed while its files were being written: {sum(during)} of {len(during)}")


# --------------------------------------------------------------------------------------------
# determinism


def test_runs_are_deterministic(tmp_path, good):
    """Two runs give byte-identical plan.json apart from the timings block, which is separate
    and last, and identical drawings, models and CAD files. The runs are two processes with
    different hash seeds, which once reordered the DXF's classes (set iteration in ezdxf)."""
    a, b = tmp_path / "a", tmp_path / "b"
    for out, seed in ((a, "1"), (b, "4")):
        cmd = [sys.executable, "-m", "meshplan", "run", str(good), "-o", str(out), "--quiet", "--ifc"]
        subprocess.run(cmd, check=True, env=dict(os.environ, PYTHONHASHSEED=seed))
    names = sorted(p.name for p in a.iterdir())
    assert names == sorted(p.name for p in b.iterdir())
    assert {"model.ifc", "drafting-0.dxf", "pen-and-ink-0.png", "drafting-0.pdf", "story-0.glb"} <= set(names)
    ta, tb = (a / "plan.json").read_text(), (b / "plan.json").read_text()
    assert list(json.loads(ta))[-1] == "timings"
    head_a, timings_a = ta.split('\n  "timings": ')
    head_b, timings_b = tb.split('\n  "timings": ')
    assert head_a == head_b  # byte-identical up to the timings block
    assert json.loads(timings_a[: -len("}\n")]).keys() == json.loads(timings_b[: -len("}\n")]).keys()
    timing = re.compile(rb'<span class="timing">[^<]*</span>')
    for name in names:
        da, db = (a / name).read_bytes(), (b / name).read_bytes()
        if name == "report.html":  # the report shows the timings too
            da, db = timing.sub(b"", da), timing.sub(b"", db)
        if name != "plan.json":
            assert da == db, name


def test_a_dead_drawing_worker_is_replaced_by_the_main_process(good):
    """A drawing worker killed (say, for memory) before or during the jobs: the main process
    draws what it left, and the files are the same."""
    import meshplan
    from meshplan.export import RenderPool, render_files

    result = meshplan.run(good)
    with RenderPool(2) as pool:
        reference = render_files(result, pool=pool)
    with RenderPool(2) as pool:
        time.sleep(0.5)
        for p in list(pool.executor._processes.values()):
            p.kill()
        again = render_files(result, pool=pool)
    mask = lambda files: {k: v for k, v in files.items() if k != "report.html"}  # noqa: E731 - it shows timings
    assert mask(again) == mask(reference)
