"""The drawing pool's shape on few cores (issue 15): the run counts as one of its drawing
processes (on 2 cores, one worker beside it), each drafting figure is made once for its three
files, and every file is the same, byte for byte, whichever process makes it."""

from __future__ import annotations

import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="drawing workers are forked on Linux only")


def test_render_pool_counts_the_run_as_one_of_its_processes():
    from meshplan.export import RenderPool

    with RenderPool(1) as alone:
        assert alone.executor is None and alone.workers == 0
    with RenderPool(2) as one:
        assert one.executor is not None and one.workers == 1
        assert one.executor.submit(int).result(timeout=60) == 0
        assert len(one.executor._processes) == 1
    with RenderPool(3) as two:
        assert two.workers == 2


def test_drafting_figure_made_once_for_its_three_files(computed):
    """A drafting plan is one job for its three files, whatever the workers: its figure is
    drawn once for all of them (meshplan.render.vector), so that splitting its formats between
    two workers would build and draw it twice."""
    from meshplan import export

    _, result = computed("apartment", 1)
    for workers in (0, 1, 2, 3):
        jobs, _ = export._jobs(result, workers)
        assert [j[7] for j in jobs if j[0] is export._drafting_files] == [("png", "svg", "pdf")]


def test_one_worker_makes_the_files_the_run_alone_makes(computed):
    """With one worker every file is the one the run makes alone (and the one two workers
    make), the report included (no timings here)."""
    from meshplan.export import RenderPool, render_files

    _, result = computed("apartment", 1)
    with RenderPool(1) as alone:
        here = render_files(result, pool=alone)
    with RenderPool(2) as pool:
        assert pool.workers == 1
        there = render_files(result, pool=pool)
    with RenderPool(3) as pool:
        split = render_files(result, pool=pool)
    assert sorted(here) == sorted(there) == sorted(split)
    for name in here:
        assert here[name] == there[name] == split[name], name



def test_each_storys_sheet_is_made_once_per_run(tmp_path, monkeypatch):
    """Every drawing of a story is on one sheet, made once per run (each is a pass over the
    faces and two quantiles: 0.1 s per story at 3M faces) and handed from the pen-and-ink plans
    to the wall segments and the drafting plans: a two-story run makes two."""
    import meshplan
    from meshplan import export
    from meshplan.export.synth import write_synthetic
    from meshplan.synthetic import SynthParams, generate

    write_synthetic(generate(SynthParams(preset="multistory", seed=1, target_faces=20_000)), tmp_path / "scan", "ply", force=True)
    made = []
    original = export.make_sheet

    def counted(points, params, *args, **kwargs):
        made.append(len(points))
        return original(points, params, *args, **kwargs)

    monkeypatch.setattr(export, "make_sheet", counted)
    result = meshplan.run(tmp_path / "scan" / "scan.ply", output=tmp_path / "out")
    assert len(result.orientation.stories) == 2
    assert len(made) == 2
    assert {f"drafting-{i}.png" for i in (0, 1)} <= set(result.files)


@pytest.mark.parametrize("processes", [1, 2])
def test_models_and_view_made_ahead_are_the_runs_files(tmp_path, monkeypatch, processes):
    """From AHEAD_MIN_FACES faces the GLB models and the report's view of the scan are made in a
    thread once the walls and openings are final: every file is the same, byte for byte (the
    timings aside), and the run does not make them again."""
    import json
    import re

    import meshplan
    from meshplan import export
    from meshplan.export.synth import write_synthetic
    from meshplan.synthetic import SynthParams, generate

    scan = write_synthetic(generate(SynthParams(preset="multistory", seed=1, target_faces=20_000)), tmp_path / "scan", "ply")
    notes = scan.parent / "annotations.json"  # the sensors: in every model, each on its story's
    assert notes.exists()
    meshplan.run(scan, annotations=notes, output=tmp_path / "after", processes=processes)
    monkeypatch.setattr(export, "AHEAD_MIN_FACES", 0)
    models = export._model_jobs

    def not_again(result):
        raise AssertionError("the models were made again after the rooms")

    monkeypatch.setattr(export, "_model_jobs", not_again)
    meshplan.run(scan, annotations=notes, output=tmp_path / "ahead", processes=processes)
    monkeypatch.setattr(export, "_model_jobs", models)
    after, ahead = tmp_path / "after", tmp_path / "ahead"
    names = sorted(p.name for p in after.iterdir())
    assert names == sorted(p.name for p in ahead.iterdir()) and {"oriented.glb", "story-1.glb", "flat-walls-0.glb"} <= set(names)
    for name in names:
        if name not in ("plan.json", "report.html"):
            assert (after / name).read_bytes() == (ahead / name).read_bytes(), name
    docs = [json.loads((d / "plan.json").read_text()) for d in (after, ahead)]
    assert [{k: v for k, v in d.items() if k != "timings"} for d in docs] == [{k: v for k, v in docs[1].items() if k != "timings"}] * 2
    # the report's 3D view is the same (its timings table aside)
    views = [re.search(r'id="meshplan-data">(.*?)</script>', (d / "report.html").read_text(), re.S) for d in (after, ahead)]
    assert views[0] is not None and views[1] is not None
    assert json.loads(views[0].group(1))["meshes"] and views[0].group(1) == views[1].group(1)


def test_models_made_ahead_of_another_mesh_are_not_taken(computed):
    """A run whose rooms stage turned part of the mesh over (a stair's upper flight) has
    another mesh than the one its models were begun from: they are made again from it."""
    from dataclasses import replace

    from meshplan.export import Ahead, _oriented_of
    from meshplan.export.view3d import MAX_FACES

    _, result = computed("apartment", 1)
    ahead = Ahead(_oriented_of(result), result.walls, result.openings, result.options.orient.slab_tolerance_m, MAX_FACES)
    made = ahead.take(result)
    assert made is not None and {"oriented.glb", "story-0.glb", "flat-walls-0.glb"} <= set(made[0])
    assert ahead.take(replace(result, mesh=result.mesh.with_flipped(result.mesh.face_normals[:, 1] > 0.9))) is None
    assert ahead.take(replace(result, openings=replace(result.openings))) is None
