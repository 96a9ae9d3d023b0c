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
