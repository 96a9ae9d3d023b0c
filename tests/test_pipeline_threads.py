"""The computing stages run with one BLAS thread (:data:`meshplan.geometry.BLAS_THREADS`):
their products are thin and the drawing workers use the other cores, so a second BLAS thread
only waits (issue 15)."""

from __future__ import annotations

import pytest
from threadpoolctl import threadpool_info

import meshplan.pipeline as pipeline
from conftest import box_room
from meshplan.geometry import Annotations, Mesh
from meshplan.io import LoadStats
from meshplan.options import RunOptions


class _Seen(Exception):
    pass


def _blas_threads() -> set[int]:
    return {int(lib["num_threads"]) for lib in threadpool_info() if lib.get("user_api") == "blas"}


def test_the_stages_run_with_one_blas_thread(monkeypatch):
    if not _blas_threads():
        pytest.skip("no BLAS library loaded")
    seen: list[set[int]] = []

    def rooms_stage(*args, **kwargs):
        seen.append(_blas_threads())
        raise _Seen

    monkeypatch.setattr(pipeline, "find_rooms", rooms_stage)
    vertices, faces = box_room()
    n_v, n_f = len(vertices), len(faces)
    stats = LoadStats("room.obj", "obj", "m", 1.0, 1, n_v, n_f, 0, 0, 0, n_v, n_f)
    with pytest.raises(_Seen):
        pipeline.compute(Mesh(vertices, faces), stats, Annotations(), RunOptions())
    assert seen == [{1}]
