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


@pytest.mark.parametrize("preset, seed", [("hard", 3), ("multistory", 2)])
def test_walls_searched_in_threads_give_the_openings_one_thread_finds(computed, monkeypatch, preset, seed):
    """find_openings searches the walls in :data:`~meshplan.plan.openings.SEARCH_THREADS`
    threads (each thread does take walls), and finds what one thread does, in the same order."""
    import threading
    import time

    import numpy as np

    import meshplan.plan.openings as op

    _, result = computed(preset, seed)
    searching = op.wall_candidates
    threads: set[int] = set()

    def search(*args):
        threads.add(threading.get_ident())
        time.sleep(0.01)  # every thread gets walls to search, however fast the first is
        return searching(*args)

    monkeypatch.setattr(op, "wall_candidates", search)
    found = {}
    for n in (1, 2):
        monkeypatch.setattr(op, "SEARCH_THREADS", n)
        threads.clear()
        found[n] = op.find_openings(result.mesh, result.orientation, result.walls, result.options.plan)
        assert len(threads) == min(n, len(result.walls))
    assert len(found[1]) >= 2
    for name in ("story", "kind", "wall", "u_min", "u_max", "bottom", "top", "faces", "closed", "ragged"):
        a, b = getattr(found[1], name), getattr(found[2], name)
        assert (np.array_equal(a, b) if isinstance(a, np.ndarray) else a == b), name
