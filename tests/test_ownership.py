"""meshplan only ever replaces a directory it made (issue 10: ``--force`` deleted the user's scan).

Each case is refused before any work, in one line, with exit status 2, and leaves every file
where it was; the cases that are allowed (an empty directory, meshplan's own earlier result, a
symbolic link to one) replace exactly that directory.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from meshplan.cli import main
from meshplan.errors import OutputError
from meshplan.io import check_output_dir, staged_directory
from meshplan.io.atomic import KIND_PLANS, KIND_SYNTHETIC, STAMP_NAME, remove_stale, write_stamp

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")


def _tree(directory: Path) -> dict[str, bytes]:
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def scan_dir(tmp_path_factory) -> Path:
    """A synthetic room (scan.obj, annotations.json, truth.json), made once."""
    d = tmp_path_factory.mktemp("synth") / "room"
    assert main(["synth", "--preset", "room", "--seed", "1", "--target-faces", "6000", "-o", str(d), "--quiet"]) == 0
    return d


def _copy_scan(scan_dir: Path, where: Path) -> Path:
    where.mkdir(parents=True, exist_ok=True)
    shutil.copy(scan_dir / "scan.obj", where / "scan.obj")
    return where / "scan.obj"


def _refused(capsys, argv: list[str], *words: str) -> str:
    code = main(argv)
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and err.startswith("error: ") and "Traceback" not in err, err
    for w in words:
        assert w in err, err
    return err


def test_force_never_deletes_the_scan_beside_it(tmp_path, scan_dir, capsys):
    """``meshplan run v/scan.obj -o v --force``: the scan's own directory is refused."""
    v = tmp_path / "v"
    scan = _copy_scan(scan_dir, v)
    (v / "notes.txt").write_text("mine")
    before = _tree(v)
    _refused(capsys, ["run", str(scan), "-o", str(v), "--force", "--quiet"], "--force", str(scan))
    assert _tree(v) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["v"]  # nothing staged beside it


def test_force_never_replaces_the_working_directory(tmp_path, scan_dir, capsys, monkeypatch):
    """``cd d && meshplan run scan.obj -o "$PWD" --force``, and ``-o .`` and ``-o ..``."""
    d = tmp_path / "d" / "e"
    _copy_scan(scan_dir, d)
    monkeypatch.chdir(d)
    before = _tree(tmp_path)
    for out in (str(d), ".", "..", "./"):
        _refused(capsys, ["run", "scan.obj", "-o", out, "--force", "--quiet"], "--force")
    assert _tree(tmp_path) == before
    assert sorted(p.name for p in d.iterdir()) == ["scan.obj"]


def test_force_refuses_a_directory_meshplan_did_not_write(tmp_path, scan_dir, capsys):
    scan = _copy_scan(scan_dir, tmp_path / "scans")
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "thesis.tex").write_text("years of work")
    _refused(capsys, ["run", str(scan), "-o", str(theirs), "--force", "--quiet"], "no .meshplan stamp")
    assert (theirs / "thesis.tex").read_text() == "years of work"


def test_force_refuses_a_result_with_a_file_added_by_hand(tmp_path, scan_dir, capsys):
    scan = _copy_scan(scan_dir, tmp_path / "scans")
    out = tmp_path / "out"
    assert main(["run", str(scan), "-o", str(out), "--quiet", "--slices", "5"]) == 0
    stamp = json.loads((out / STAMP_NAME).read_text())
    assert stamp["kind"] == KIND_PLANS and "plan.json" in stamp["files"] and STAMP_NAME not in stamp["files"]
    assert sorted(stamp["files"]) == sorted(p.name for p in out.iterdir() if p.name != STAMP_NAME)
    (out / "my-markup.pdf").write_bytes(b"%PDF mine")
    _refused(capsys, ["run", str(scan), "-o", str(out), "--force", "--quiet"], "my-markup.pdf", "did not write")
    assert (out / "my-markup.pdf").read_bytes() == b"%PDF mine"
    # once the file is moved out, the same result is replaced
    (out / "my-markup.pdf").unlink()
    (out / "plan.json").write_text("stale")
    assert main(["run", str(scan), "-o", str(out), "--force", "--quiet", "--slices", "5"]) == 0
    assert json.loads((out / "plan.json").read_text())["stories"]


def test_force_refuses_a_synthetic_scan_directory_as_plans(tmp_path, scan_dir, capsys):
    """A synthetic scan's directory is meshplan's, but of another kind: it holds the scan."""
    room = tmp_path / "room"
    shutil.copytree(scan_dir, room)
    assert json.loads((room / STAMP_NAME).read_text())["kind"] == KIND_SYNTHETIC
    before = _tree(room)
    _refused(capsys, ["run", str(room / "scan.obj"), "-o", str(room), "--force", "--quiet"], "--force")
    # through the API too, without the scan inside (the kind alone protects it)
    with pytest.raises(OutputError, match="synthetic scan"):
        check_output_dir(room, True, kind=KIND_PLANS)
    assert _tree(room) == before


def test_force_replaces_an_empty_directory_and_meshplans_own(tmp_path, scan_dir):
    scan = _copy_scan(scan_dir, tmp_path / "scans")
    empty = tmp_path / "empty"
    empty.mkdir()
    assert main(["run", str(scan), "-o", str(empty), "--force", "--quiet", "--slices", "5"]) == 0
    assert (empty / "plan.json").is_file() and (empty / STAMP_NAME).is_file()
    assert main(["run", str(scan), "-o", str(empty), "--force", "--quiet", "--slices", "5"]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["empty", "scans"]


def test_symlinked_output_replaces_its_directory_and_leaves_nothing(tmp_path, scan_dir, capsys):
    """A symbolic link as ``-o --force``: the directory it names is replaced, the link kept,
    and no hidden leftover stays beside either (it used to leave a ``.NAME.meshplan-tmp-*``)."""
    scan = _copy_scan(scan_dir, tmp_path / "scans")
    real = tmp_path / "real"
    assert main(["run", str(scan), "-o", str(real), "--quiet", "--slices", "5"]) == 0
    link = tmp_path / "link"
    link.symlink_to(real, target_is_directory=True)
    assert main(["run", str(scan), "-o", str(link), "--force", "--quiet", "--slices", "6"]) == 0
    assert link.is_symlink() and (link / "plan.json").is_file()
    assert json.loads((real / "plan.json").read_text())["parameters"]["plan"]["slices"] == 6
    assert sorted(p.name for p in tmp_path.iterdir()) == ["link", "real", "scans"]
    dangling = tmp_path / "dangling"
    dangling.symlink_to(tmp_path / "nowhere")
    _refused(capsys, ["run", str(scan), "-o", str(dangling), "--quiet"], "symbolic link to nothing")
    assert not (tmp_path / "nowhere").exists()


def test_stale_symlink_leftovers_are_unlinked_not_followed(tmp_path):
    victim = tmp_path / "victim"
    victim.mkdir()
    (victim / "keep").write_text("x")
    dead = 2**22 + 4321  # above the default pid_max: no such process
    stale = tmp_path / f".out.meshplan-tmp-{dead}-abcdefgh"
    stale.symlink_to(victim, target_is_directory=True)
    remove_stale(tmp_path / "out")
    assert not os.path.lexists(stale) and (victim / "keep").read_text() == "x"


def test_output_name_too_long_is_refused_up_front(tmp_path, scan_dir, capsys):
    scan = _copy_scan(scan_dir, tmp_path / "scans")
    out = tmp_path / ("x" * 240)
    _refused(capsys, ["run", str(scan), "-o", str(out), "--quiet"], "output name too long", "shorter")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["scans"]


def test_staged_directory_stamps_what_it_wrote(tmp_path):
    out = tmp_path / "out"
    with staged_directory(out) as tmp:
        (tmp / "a.txt").write_text("a")
        (tmp / "b.txt").write_text("b")
    stamp = json.loads((out / STAMP_NAME).read_text())
    assert stamp["files"] == ["a.txt", "b.txt"] and stamp["kind"] == KIND_PLANS
    write_stamp(out, KIND_SYNTHETIC)
    with pytest.raises(OutputError, match="synthetic scan"):
        check_output_dir(out, True)
