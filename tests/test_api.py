"""The Python API: ``meshplan.run`` takes the command line's parameters (the CLI is a thin layer
over it), and the README's example runs as written."""

from __future__ import annotations

import contextlib
import io
import re
from pathlib import Path

import pytest

from meshplan.cli import main
from meshplan.errors import MeshplanError
from meshplan.export.synth import write_synthetic
from meshplan.options import RunOptions
from meshplan.synthetic import SynthParams, generate

README = Path(__file__).resolve().parents[1] / "README.md"


def _python_blocks(text: str) -> list[str]:
    return re.findall(r"```python\n(.*?)```", text, flags=re.S)


def test_readme_starts_with_the_two_commands_and_documents_the_api_and_batch():
    text = README.read_text(encoding="utf-8")
    first = [ln.split("#")[0].strip() for ln in text.splitlines()[:2]]
    assert first == ["make demo", "make test"]
    assert any("meshplan.run(" in block for block in _python_blocks(text))
    for words in ("meshplan batch", "--workers", "--scheduler", "summary.csv", "--quiet", "--json", "-v"):
        assert words in text, words


@pytest.mark.slow
def test_readme_example_runs(tmp_path, monkeypatch):
    (block,) = [b for b in _python_blocks(README.read_text(encoding="utf-8")) if "meshplan.run(" in b]
    # the scan the example names ('meshplan synth --preset room --seed 1 -o room'), coarser to be quick
    write_synthetic(generate(SynthParams(preset="room", seed=1, triangle_size_m=(0.12, 0.2))), tmp_path / "room")
    monkeypatch.chdir(tmp_path)
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        exec(compile(block, "README.md", "exec"), {"__name__": "readme"})
    text = printed.getvalue()
    assert "story 0: floor" in text and "flat walls" in text and "'timings'" in text
    assert (tmp_path / "room-plans" / "plan.json").is_file() and (tmp_path / "room-plans" / "report.html").is_file()


class _Stop(MeshplanError):
    pass


def test_the_cli_is_a_thin_layer_over_meshplan_run(tmp_path, monkeypatch, capsys):
    """Every option of ``meshplan run`` reaches :func:`meshplan.pipeline.run` as the keyword
    parameter of the same meaning, which ``meshplan.run`` accepts as well."""
    import meshplan.api

    calls: list[tuple[tuple, dict]] = []

    def fake_run(*args, **kwargs):
        calls.append((args, kwargs))
        raise _Stop("stopped by the test")

    monkeypatch.setattr(meshplan.api, "run", fake_run)
    argv = [
        "run", "scan.ply", "-o", str(tmp_path / "out"), "-a", "ann.json", "--force",
        "--units", "cm", "--up", "+z", "--gravity", "bbox", "--slices", "17", "--opacity", "0.3",
        "--imperial", "--scale", "50", "--dpi", "90", "--drafting-height", "1.1", "--box-length", "0.5",
        "--box-depth", "0.07", "--box-height", "2.2", "--min-points", "9", "--wall-directions", "all",
        "--min-wall-length", "0.4", "--floor-reach", "0.3", "--ceiling-reach", "0.35",
        "--min-room-height", "1.9", "--default-ceiling-height", "2.5", "--max-faces", "123456",
        "--set", "gravity_plane_fit=false",
    ]  # fmt: skip
    assert main(argv) == 2
    assert "stopped by the test" in capsys.readouterr().err
    ((args, kwargs),) = calls
    assert args == (Path("scan.ply"),)
    assert kwargs.pop("annotations") == Path("ann.json") and kwargs.pop("output") == tmp_path / "out"
    assert kwargs.pop("force") is True and callable(kwargs.pop("progress"))
    # the rest are run options, under the names meshplan.run takes
    options = RunOptions.from_kwargs(**kwargs)
    flat = {k: v for group in options.to_dict().values() for k, v in group.items()}
    expected = {
        "units": "cm", "up": "+z", "gravity_method": "bbox", "slices": 17, "opacity": 0.3, "imperial": True,
        "scale": 50, "dpi": 90, "drafting_height_m": 1.1, "box_length_m": 0.5, "box_depth_m": 0.07,
        "box_height_m": 2.2, "min_points": 9, "wall_directions": "all", "min_wall_length_m": 0.4,
        "floor_reach_m": 0.3, "ceiling_reach_m": 0.35, "min_room_height_m": 1.9,
        "default_ceiling_height_m": 2.5, "max_faces": 123456, "gravity_plane_fit": False,
    }  # fmt: skip
    assert {k: flat[k] for k in expected} == expected
    # meshplan.run forwards the same keywords unchanged
    calls.clear()
    with pytest.raises(_Stop):
        meshplan.run("scan.ply", output=None, **kwargs)
    assert calls == [(("scan.ply",), {"output": None, **kwargs})]


def test_plan_json_maps_georeferenced_coordinates_to_the_micrometre():
    """A scan exported in georeferenced coordinates (UTM: 512 km east, 4,123 km north) gives the
    same plan as the same scan around the origin, and plan.json's ``transform`` maps its input
    coordinates onto that plan. Rounded to six decimals, its rotation moved them by up to 2 m
    (the real scans' walls, so moved, matched none of their truth's)."""
    import numpy as np

    from meshplan.export.planjson import plan_document
    from meshplan.geometry import Annotations, Mesh
    from meshplan.io import LoadStats
    from meshplan.pipeline import compute

    scan = generate(SynthParams(preset="room", seed=1))
    m = scan.mesh
    offset = np.array([512345.678, 87.5, 4123456.789])
    runs = []
    for mesh in (m, Mesh(np.asarray(m.vertices) + offset, np.asarray(m.faces))):
        stats = LoadStats("synthetic", "obj", "m", 1.0, 1, mesh.n_vertices, mesh.n_faces, 0, 0, 0, mesh.n_vertices, mesh.n_faces)
        r = compute(mesh, stats, Annotations(), RunOptions())
        runs.append((mesh, r, plan_document(r)))
    (m0, r0, doc0), (m1, r1, doc1) = runs
    t = np.asarray(doc1["transform"])
    mapped = np.asarray(m1.vertices) @ t[:3, :3].T + t[:3, 3]
    exact = np.asarray(m1.vertices) @ r1.orientation.transform[:3, :3].T + r1.orientation.transform[:3, 3]
    assert np.abs(mapped - exact).max() < 1e-5
    # the same plan either way, to the plan's own rounding
    assert len(doc1["walls"]) == len(doc0["walls"])
    ends = [np.asarray([w["start"] + w["end"] for w in d["walls"]]) for d in (doc0, doc1)]
    assert np.abs(ends[1] - ends[0]).max() < 1e-3
