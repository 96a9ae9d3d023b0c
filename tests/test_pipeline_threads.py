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


def _threads_seen(monkeypatch, module, name: str) -> set[int]:
    """The threads that call ``module.name`` from now on (each call a little slow, so that
    every thread of a pool gets parts however fast the first is)."""
    import threading
    import time

    seen: set[int] = set()
    searching = getattr(module, name)

    def search(*args):
        seen.add(threading.get_ident())
        time.sleep(0.01)
        return searching(*args)

    monkeypatch.setattr(module, name, search)
    return seen


def _same(a, b, fields: tuple[str, ...]) -> None:
    import numpy as np

    for name in fields:
        x, y = getattr(a, name), getattr(b, name)
        assert (np.array_equal(x, y) if isinstance(x, np.ndarray) else x == y), name


def _one_and_two_threads(monkeypatch, module, name: str, compute):
    """``compute()`` with :data:`~meshplan.geometry.SEARCH_THREADS` 1 and 2, each time checking
    that as many threads called ``module.name``."""
    import meshplan.geometry as geometry

    threads = _threads_seen(monkeypatch, module, name)
    out = []
    for n in (1, 2):
        monkeypatch.setattr(geometry, "SEARCH_THREADS", n)
        threads.clear()
        out.append(compute())
        assert len(threads) == n
    return out


@pytest.mark.parametrize("preset, seed", [("hard", 3), ("multistory", 2)])
def test_walls_searched_in_threads_give_the_openings_one_thread_finds(computed, monkeypatch, preset, seed):
    """find_openings searches the walls in :data:`~meshplan.geometry.SEARCH_THREADS` threads
    (each thread does take walls), and finds what one thread does, in the same order."""
    import meshplan.plan.openings as op

    _, result = computed(preset, seed)
    one, two = _one_and_two_threads(monkeypatch, op, "wall_candidates", lambda: op.find_openings(result.mesh, result.orientation, result.walls, result.options.plan))
    assert len(one) >= 2
    _same(one, two, ("story", "kind", "wall", "u_min", "u_max", "bottom", "top", "faces", "closed", "ragged"))


@pytest.mark.parametrize("preset, seed", [("hard", 1), ("multistory", 2)])
def test_directions_searched_in_threads_give_the_walls_one_thread_finds(computed, monkeypatch, preset, seed):
    """find_flat_walls searches each story's wall directions in threads (each thread does take
    directions), and finds the walls one thread does, numbered the same."""
    import meshplan.walls.flat as flat

    _, result = computed(preset, seed)
    one, two = _one_and_two_threads(monkeypatch, flat, "box_dbscan", lambda: flat.find_flat_walls(result.mesh, result.orientation, result.options.walls))
    assert len(one) >= 4
    _same(one, two, ("story", "direction", "normal", "offset", "u_min", "u_max", "bottom", "top", "face_segment", "segment_story", "segment_kept", "segment_wall"))


def test_openings_looked_at_in_threads_give_the_elements_one_thread_gives(computed, monkeypatch):
    """opening_elements looks at the openings in threads (each thread does take openings), and
    gives the elements one thread gives, in the openings' order."""
    import meshplan.plan.elements as elements

    _, r = computed("multistory", 2)
    one, two = _one_and_two_threads(
        monkeypatch, elements, "_rooms_near",
        lambda: elements.opening_elements(r.openings, r.walls, r.physical_walls, r.rooms, r.orientation.stories, r.mesh, r.options.plan),
    )
    assert len(one) == len(r.openings) >= 2
    assert [e.to_dict() for e in one] == [e.to_dict() for e in two] == [e.to_dict() for e in r.opening_elements]


@pytest.mark.parametrize("select", [False, True])
def test_a_mesh_sliced_in_threads_gives_the_slices_of_one_pass(computed, monkeypatch, select):
    """slice_mesh cuts a large mesh's faces in consecutive runs in threads (each thread does
    cut), and joins the same segments, levels and faces (indexing ``select``) as one pass."""
    import numpy as np

    import meshplan.slicing as slicing

    _, r = computed("multistory", 2)
    story = r.orientation.stories[0]
    heights = np.linspace(story.floor + 0.05, story.ceiling - 0.05, 101)
    faces = np.flatnonzero(r.orientation.face_story == 0)[::-1] if select else None  # any order
    monkeypatch.setattr(slicing, "SLICE_THREAD_MIN_FACES", r.mesh.n_faces // 5)
    one, two = _one_and_two_threads(monkeypatch, slicing, "_slice_rows", lambda: slicing.slice_mesh(r.mesh.triangles, heights, faces))
    assert len(one) > 1000
    _same(one, two, ("segments", "level", "face"))
