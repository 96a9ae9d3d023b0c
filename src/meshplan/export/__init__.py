"""Writing a result: plan.json, 3D models, drawings and CAD files, all into one directory that
appears atomically (see :func:`meshplan.io.staged_directory`)."""

from __future__ import annotations

import gc
import logging
import os
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from ..io import staged_directory
from ..render import (
    drafting_figure,
    figure_bytes,
    figure_files,
    levels_figure,
    make_sheet,
    normals_heat_map,
    normals_histogram,
    pen_and_ink_figure,
    segments_figure,
)
from ..result import Oriented
from .dxf import drafting_dxf
from .glb import WALL_RGBA, glb_bytes, submesh
from .planjson import dumps, plan_document, plan_schema
from .report import report_html, report_page

if TYPE_CHECKING:  # pragma: no cover
    from concurrent.futures import Future

    from ..geometry import Mesh
    from ..orient import Orientation
    from ..plan import PenAndInkPlan
    from ..render.params import RenderParams
    from ..render.sheet import Sheet
    from ..result import Result, _Timer
    from ..walls import FlatWalls

log = logging.getLogger(__name__)

__all__ = [
    "EarlyDrawings",
    "RenderPool",
    "Written",
    "dumps",
    "plan_document",
    "plan_schema",
    "render_files",
    "submit_early",
    "submit_upright",
    "submit_walls",
    "write_results",
]


# ---------------------------------------------------------------------------------------------
# Jobs: each makes a few files from plain arrays and small dataclasses, in this process or in a
# worker. Their arguments are all they read, so they can run in workers forked before the
# result existed (see RenderPool).


def _pen_files(plan, annotations, sheet, params, n_stories: int, fmts: tuple[str, ...], scan: str = "", north_deg: float = 0.0) -> dict[str, bytes]:
    fig = pen_and_ink_figure(plan, annotations, sheet, params, n_stories, scan=scan, north_deg=north_deg)
    return {f"pen-and-ink-{plan.story.index}.{fmt}": data for fmt, data in figure_files(fig, fmts).items()}


def _drafting_files(
    plan, annotations, sheet, params, n_stories: int, symbols, fmts: tuple[str, ...], scan: str = "", north_deg: float = 0.0
) -> dict[str, bytes]:
    fig = drafting_figure(plan, annotations, sheet, params, n_stories, symbols, scan=scan, north_deg=north_deg)
    return {f"drafting-{plan.story.index}.{fmt}": data for fmt, data in figure_files(fig, fmts).items()}


def _segments_files(centroids, walls, story: int, sheet, params, n_stories: int) -> dict[str, bytes]:
    return {f"wall-segments-{story}.png": figure_bytes(segments_figure(centroids, walls, story, sheet, params, n_stories), "png")}


def _normals_files(hist, orientation) -> dict[str, bytes]:
    """normals.png from the faces' direction histogram (:func:`~meshplan.render.plots.normals_histogram`)."""
    return {"normals.png": figure_bytes(normals_heat_map(hist, orientation), "png")}


def _levels_files(orientation, params) -> dict[str, bytes]:
    return {"levels.png": figure_bytes(levels_figure(orientation, params), "png")}


def _dxf_files(story: int, walls_cut, reference, annotations, symbols, rooms) -> dict[str, bytes]:
    data = drafting_dxf(walls_cut, reference, annotations, f"meshplan drafting plan, story {story}", symbols, rooms)
    return {f"drafting-{story}.dxf": data}


def _story_model_files(vertices, faces, model_faces, walls_mesh, annotations, story: int) -> dict[str, bytes]:
    """A story without its ceiling and its flat walls, as GLB models. The scan comes as its
    ``vertices`` and ``faces`` alone: a :class:`~meshplan.geometry.Mesh` would carry its cached
    per-face arrays (five times the size) to the worker."""
    from ..geometry import Mesh

    # the run's mesh's own arrays (or their copies unpickled in a worker), valid: taken as they
    # are (Mesh() would copy and check them, 0.1 s at 3M faces)
    return {
        f"story-{story}.glb": glb_bytes(submesh(Mesh._adopt(vertices, faces), model_faces), annotations, f"story {story}"),
        f"flat-walls-{story}.glb": glb_bytes(walls_mesh, annotations, f"flat walls {story}", WALL_RGBA),
    }


def _oriented_files(vertices, faces, annotations) -> dict[str, bytes]:
    from ..geometry import Mesh

    return {"oriented.glb": glb_bytes(Mesh._adopt(vertices, faces), annotations, "scan")}  # (as above)


def _model_jobs(result: Result) -> list[tuple]:
    """``(function, *arguments)`` of the GLB models: each story's, then the whole scan's."""
    mesh = result.mesh
    holes = result.openings.holes()
    jobs: list[tuple] = [
        (_story_model_files, mesh.vertices, mesh.faces, sp.model_faces, result.walls.mesh(sp.story.index, holes), sp.annotations, sp.story.index)
        for sp in result.stories
    ]
    jobs.append((_oriented_files, mesh.vertices, mesh.faces, result.annotations))
    return jobs


def _early_jobs(oriented: Oriented, sheets: tuple[Sheet, ...]) -> list[tuple]:
    """``(function, *arguments)`` of the drawings the oriented scan alone decides: each story's
    pen-and-ink plan (slowest first, :func:`_pen_jobs`), then those of :func:`_upright_jobs`."""
    return _pen_jobs(oriented, sheets) + _upright_jobs(oriented.orientation, oriented.mesh, oriented.options.render)


def _pen_jobs(oriented: Oriented, sheets: tuple[Sheet, ...]) -> list[tuple]:
    """``(function, *arguments)`` of each story's pen-and-ink plan, on its sheet of ``sheets``."""
    o, params = oriented.orientation, oriented.options.render
    n = len(o.stories)
    scan, north = _title(oriented)
    return [
        (_pen_files, _drawn_slices(pen), ann, sheets[story.index], params, n, ("png", "svg", "pdf"), scan, north)
        for story, pen, ann in zip(o.stories, oriented.pen_and_ink, oriented.story_annotations, strict=True)
    ]


def _upright_jobs(orientation: Orientation, mesh: Mesh, params: RenderParams) -> list[tuple]:
    """``(function, *arguments)`` of the drawings the orientation alone decides (the normals,
    the levels), before the pen-and-ink plans are cut: the run submits them as soon as the scan
    is oriented (:func:`submit_upright`), so that its worker draws them while the slices are
    computed."""
    # the figures read the orientation's levels, stories and wall directions, not its per-face
    # arrays (2.7 MB of the 300k-face apartment's, pickled to the worker for each figure)
    light = replace(orientation, face_story=orientation.face_story[:0], flipped=orientation.flipped[:0])
    return [(_normals_files, normals_histogram(mesh.face_normals, mesh.face_areas), light), (_levels_files, light, params)]


def _drawn_slices(pen: PenAndInkPlan) -> PenAndInkPlan:
    """``pen`` with what its drawing reads of the slices alone: the segments and their planes,
    not the face each segment cuts. The plan is pickled to a worker: 17.3 MB on the 300k-face
    apartment (0.07 s to pickle in the run, as long to unpickle in the worker), 14.4 MB so."""
    return replace(pen, slices=replace(pen.slices, face=pen.slices.face[:0]))


def _oriented_of(result: Result) -> Oriented:
    """What of ``result`` the oriented scan alone decided (for :func:`_early_jobs`)."""
    pens = tuple(sp.pen_and_ink for sp in result.stories)
    anns = tuple(sp.annotations for sp in result.stories)
    return Oriented(result.input, result.options, result.orientation, result.mesh, pens, anns, result.annotation_story)


def _title(oriented: Oriented | Result) -> tuple[str, float]:
    """``(scan, north)`` of the title block: the scan file (not its directory), --north-deg."""
    return Path(oriented.input.path).name, oriented.options.export.north_deg


def _sheets(oriented: Oriented | Result) -> tuple[Sheet, ...]:
    """The sheet of every plan of each story (by index): the page around the story's faces.
    Made once per run and handed to each drawing of the story (:class:`EarlyDrawings`): each
    is a pass over the faces' centroids and two quantiles, 0.1 s per story at 3M faces."""
    o, mesh = oriented.orientation, oriented.mesh
    xz = mesh.face_centroids[:, [0, 2]]
    return tuple(make_sheet(xz[o.face_story == s.index], oriented.options.render) for s in o.stories)


def _segments_jobs(oriented: Oriented | Result, walls: FlatWalls, sheets: tuple[Sheet, ...]) -> list[tuple]:
    """``(function, *arguments)`` of each story's wall segments figure: the flat walls alone
    decide it, so the run submits it once they are final, before the rooms (:func:`submit_walls`)."""
    params, n = oriented.options.render, len(oriented.orientation.stories)
    centroids = oriented.mesh.face_centroids
    return [(_segments_files, centroids, walls, s.index, sheets[s.index], params, n) for s in oriented.orientation.stories]


def _jobs(result: Result, workers: int = 2, segments: bool = True, sheets: tuple[Sheet, ...] | None = None) -> tuple[list[tuple], list[tuple]]:
    """``(function, *arguments)`` of the drawings that need the walls and rooms (the drafting
    plans, and the wall segments unless ``segments`` is false: :func:`submit_walls` handed them
    over), slowest first, and of the DXF files, on ``sheets`` (:func:`_sheets` by default). The
    jobs are the same for any number of ``workers`` (kept for the callers: the drafting plans
    were split between two workers before each figure was drawn once for its files)."""
    params = result.options.render
    n = len(result.stories)
    jobs: list[tuple] = []
    dxf: list[tuple] = []
    scan, north = _title(result)
    sheets = sheets if sheets is not None else _sheets(result)
    for sp in result.stories:
        i = sp.story.index
        sheet = sheets[i]
        symbols = sp.symbols
        # one job per drafting plan, whatever the workers: its figure is drawn once for its
        # three files (render.vector), so that two workers splitting its formats would each
        # build and draw it (before, two workers drew its raster and vector files at once)
        jobs.append((_drafting_files, sp.drafting, sp.annotations, sheet, params, n, symbols, ("png", "svg", "pdf"), scan, north))
        if segments:
            jobs.append((_segments_files, result.mesh.face_centroids, result.walls, i, sheet, params, n))
        rooms = [r for r in result.rooms if r.story == i]
        dxf.append((_dxf_files, i, sp.drafting.slices.segments, sp.reference, sp.annotations, symbols, rooms))
    return jobs, dxf


@contextmanager
def _no_collections() -> Iterator[None]:
    """Run the block without the cyclic garbage collector (as it was after it).

    A drawing makes and drops tens of thousands of small matplotlib objects (transforms, paths,
    texts), which reference counting frees; meanwhile the collector, run every 700 allocations,
    kept scanning the process's heap (the libraries, the figure) and found little: about 11 % of
    the drawings' CPU time on the 300k-face apartment (medians of seven passes over every
    drawing, in one process: 2.69 s with it, 2.39 s without). What a job leaves in cycles (its
    figures) is collected after it, as usual.
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _call(job: tuple) -> dict[str, bytes]:
    with _no_collections():
        return job[0](*job[1:])


#: ``PR_SET_PDEATHSIG`` from <linux/prctl.h>: the signal a process gets when its parent dies.
_PR_SET_PDEATHSIG = 1
#: Seconds between two looks at the parent where the kernel cannot signal its death (no
#: prctl): a dead run's workers hold 170-240 MB each, which may linger this long at most.
_PARENT_POLL_S = 1.0


def _die_with_parent(parent: int) -> None:
    """Make this worker die as soon as ``parent`` (the run that forked it) does, however it
    dies: SIGKILL and the OOM killer leave a process no chance to stop its children.

    On Linux the kernel sends SIGKILL to the worker when its parent exits
    (``prctl(PR_SET_PDEATHSIG)``); the parent may have died between the fork and this call,
    which the kernel would not report, so the parent is checked right after. Elsewhere (or if
    prctl fails) a daemon thread watches for the worker being reparented.
    """
    import signal

    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
                if os.getppid() != parent:  # died before prctl took effect
                    os._exit(1)
                return
        except (OSError, AttributeError):  # pragma: no cover - no libc prctl: poll instead
            pass
    import threading

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(_PARENT_POLL_S)
        os._exit(1)

    if os.getppid() != parent:
        os._exit(1)
    threading.Thread(target=watch, name="meshplan-parent-watch", daemon=True).start()


#: How much lower (in nice steps) a drawing worker runs while it warms up beside the stages.
_WARM_UP_NICE = 10


def _start_worker(parent: int, nice: bool = True) -> None:
    """A drawing worker's first steps: die with ``parent``, leave Ctrl-C to it, yield the CPU
    to the process computing the stages (the drawings wait for it anyway) when ``nice``, get
    the libraries ready, then take the run's priority back for the drawings where the system
    allows it.

    :class:`RenderPool` asks for ``nice`` only when the run and its workers outnumber the cores:
    otherwise each has a core of its own, and the low priority would only yield the CPU to
    other programs. On a machine other jobs kept busy, the one worker of a 2-core run, niced,
    took 2.7-4.4 s to warm up (0.45 s of CPU) while the run computed its stages, then kept the
    run waiting 2.2 s for its drawings.
    """
    import signal

    # Ctrl-C reaches the whole process group: the run reports it in one line and stops the
    # workers itself; a worker interrupted mid-job would only print a traceback. The worker
    # was forked with SIGINT blocked (see RenderPool), so none arrives before it is ignored.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
    _die_with_parent(parent)
    priority = os.getpriority(os.PRIO_PROCESS, 0)
    if nice:
        try:
            os.nice(_WARM_UP_NICE)
        except OSError:  # pragma: no cover - not allowed here: run at the same priority
            pass
    _warm_up()
    # The low priority is for the warm-up alone: the drawings are what the run waits for once
    # its stages are done. Left at nice 10, on a machine other jobs keep busy the workers got a
    # fraction of the CPU and drew the 300k-face apartment in 4.7 s instead of 1.1-2.0 s
    # (medians of 4 runs, load 4-5 on 2 cores). Raising a priority back needs the right to
    # (CAP_SYS_NICE, or RLIMIT_NICE); without it the drawings stay at low priority, as before.
    try:
        os.setpriority(os.PRIO_PROCESS, 0, priority)
    except OSError:  # pragma: no cover - not allowed here
        pass


def _warm_up() -> None:
    """Get matplotlib ready while the run computes its stages: a fresh process's first figure
    imports matplotlib, loads the fonts and sets up each backend (about 0.4 s), which would
    otherwise delay the first drawing by as much. The workers only draw: the DXF files and the
    GLB models are made by the run itself while it waits for the drawings (see
    :func:`render_files`), so ezdxf and trimesh's exporter are not imported here.

    matplotlib is loaded with the garbage collector paused, then set aside from it for good, as
    the program loads its own libraries (:func:`meshplan._memory.pause_collector`): the warm-up
    0.25-0.28 s instead of 0.30-0.34 s (five fresh processes each), and the drawings'
    collections no longer walk matplotlib's objects."""
    from .._memory import pause_collector, resume_collector

    pause_collector()
    try:
        _warm_matplotlib()
    finally:
        resume_collector()


def _warm_matplotlib() -> None:
    """Draw one small figure and write it in every format, once (see :func:`_warm_up`): the
    fonts are found and loaded, Agg and the direct SVG and PDF writers imported."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(1.0, 1.0), dpi=30)
    ax = fig.add_axes((0.2, 0.2, 0.6, 0.6))
    ax.plot([0.0, 1.0], [0.0, 1.0])
    ax.set_xlabel("x (m)", fontsize=6)
    fig.text(0.1, 0.9, "Plan 1.00 m²", fontsize=9, weight="bold")
    figure_files(fig, ("png", "pdf", "svg"))


def _processes(params) -> int:
    """Processes that draw (:class:`RenderPool`): the run itself and its workers (forked:
    Linux only; elsewhere the run alone)."""
    if not sys.platform.startswith("linux"):
        return 1
    n = params.processes or min(os.cpu_count() or 1, 4)
    return max(1, int(n))


#: Whether the objects a run's process holds when it forks its drawing workers are set aside
#: from the cyclic garbage collector until the run ends (``gc.freeze``, as Python's
#: documentation advises before a fork): the libraries' objects live as long as the process,
#: yet each full collection of the run went over all of them, and wrote to their pages, which a
#: forked worker shares until either writes (each write then copies the page). On the 300k-face
#: apartment the run's collections took 0.05 s instead of 0.08 s (the full one 0.01 s instead
#: of 0.05 s). They are collected as before once the run ends (``gc.unfreeze``). Where objects
#: are frozen already (the ``meshplan`` program froze its libraries once loaded,
#: :func:`meshplan._memory.resume_collector`; or a caller its own), the run leaves the freezing
#: to whoever froze them: it neither freezes nor thaws, which would thaw theirs too.
FROZEN_DURING_RUN = True


class RenderPool:
    """Worker processes that draw the plans, started before there is anything to draw.

    :func:`meshplan.api.run` opens one when a run starts: the workers are forked while the
    process is still small, and each gets matplotlib ready (:func:`_warm_up`; at low priority
    where the workers and the run outnumber the cores) on the other cores while this process
    reads the scan and orients it. The drawings that need the orientation alone (the pen-and-ink
    plans, the normals, the levels) are handed to them as soon as it is known
    (:func:`submit_early`) and drawn while the walls and rooms are computed; the drafting plans
    follow. The jobs get what they draw as arguments.

    ``processes`` counts the processes at work, this one included: ``processes - 1`` workers
    draw while this process computes the stages and then makes the models and CAD files (one
    process per core: on 2 cores, one worker). A second worker on 2 cores did not pay for
    itself (issue 15): the run's stages keep one core busy, the two workers shared the other,
    and each warmed matplotlib up (0.45 s of CPU) for the same drawings; with one worker the
    300k-face apartment ran in the same wall time with 16 % less CPU (medians of 8 fresh runs,
    interleaved). With ``processes`` 1 (or off Linux) there are no workers and everything is
    drawn here.
    """

    def __init__(self, processes: int) -> None:
        self.executor = None
        self.frozen = False
        #: whether the workers were found stuck and killed (:func:`_result`): the jobs left are
        #: drawn here
        self.stuck = False
        self.workers = max(0, int(processes) - 1) if sys.platform.startswith("linux") else 0
        if self.workers:
            import multiprocessing
            import signal
            from concurrent.futures import ProcessPoolExecutor

            from .._kernels import load_machinery

            # numba's machinery, which the run loads anyway, loaded before the fork: the worker
            # inherits it for its pen-and-ink rasters instead of loading it again (0.2 s)
            load_machinery()
            # SIGINT blocked while forking: a Ctrl-C then waits for this process (which reports
            # it in one line) instead of reaching a worker before it ignores it
            blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
            # the objects the process holds now (the libraries': some 70,000) set aside from
            # the cyclic collector for the run (see FROZEN_DURING_RUN)
            self.frozen = FROZEN_DURING_RUN and gc.get_freeze_count() == 0
            if self.frozen:
                gc.freeze()
            try:
                self.executor = ProcessPoolExecutor(
                    self.workers,
                    mp_context=multiprocessing.get_context("fork"),
                    initializer=_start_worker,
                    initargs=(os.getpid(), self.workers + 1 > (os.cpu_count() or 1)),
                )
                self.executor.submit(int)  # fork the workers now (not at the first job)
            except OSError as exc:  # no processes left to fork: draw here
                log.debug("no drawing workers (%s); drawing in this process", exc)
                self.executor, self.workers = None, 0
            finally:
                signal.pthread_sigmask(signal.SIG_SETMASK, blocked)

    def __enter__(self) -> RenderPool:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if self.frozen:  # collected as before from now on (a program may run meshplan often)
            gc.unfreeze()
            self.frozen = False
        if self.executor is None:
            return
        if exc_type is not None:
            # interrupted or failed: the drawings are not wanted, and waiting for the jobs
            # under way (workers ignore Ctrl-C) would delay the exit by seconds
            self.terminate()
        self.executor.shutdown(wait=True, cancel_futures=True)

    def processes(self) -> dict:
        """The workers, ``pid -> multiprocessing.Process`` (none without an executor). The
        executor keeps them in ``_processes``, which it does not publish otherwise."""
        return dict(getattr(self.executor, "_processes", None) or {})

    def terminate(self) -> None:
        """Kill the workers now (their jobs are lost)."""
        processes = self.processes()
        for proc in processes.values():
            try:
                proc.kill()
            except (OSError, ValueError):  # already gone or closed
                pass
        for proc in processes.values():
            try:
                proc.join(timeout=5.0)
            except (OSError, ValueError, AssertionError):  # pragma: no cover - already reaped
                pass
        # A worker killed while it sent a result leaves half a message in the result pipe, which
        # the executor's manager thread then waits on for ever (this process holds the pipe's
        # other write end), and the shutdown with it: the run hung on Ctrl-C or a failure while
        # writing (seen once in the test suite). With that end closed the thread reads the end
        # of the pipe, finds the pool broken and shuts it down. (The executor publishes neither
        # its queues nor its workers; the names are CPython's since 3.3.)
        if processes:
            writer = getattr(getattr(self.executor, "_result_queue", None), "_writer", None)
            if writer is not None:
                writer.close()


def _submit(pool: RenderPool, jobs: list[tuple]) -> list:
    """The jobs' futures from the pool's workers, or ``None`` for each when there are none."""
    if pool.executor is None:
        return [None] * len(jobs)
    from concurrent.futures.process import BrokenProcessPool

    try:
        return [pool.executor.submit(_call, job) for job in jobs]
    except BrokenProcessPool:  # a worker died before the jobs came (killed for memory)
        log.warning("a drawing worker died; drawing in the main process instead")
        return [None] * len(jobs)


#: How long (s) the run waits for a drawing while its workers use no CPU at all before it takes
#: them for stuck, kills them and draws here. A drawing worker at work always uses CPU (it
#: draws, or reads its job from the pipe); one that uses none while the run waits will never
#: answer: stopped by a signal, or forked while another thread of the run's process held a lock
#: the worker then needs (a library caller's threads: the command forks before it starts any),
#: which waits forever. Minutes would be as right; this is long beside any pause of a worker on
#: a loaded machine (a worker at nice 10 among 20 busy processes on 2 cores still gets 1 %).
WORKER_STALL_S = 30.0
#: How often (s) the waiting run looks at its workers' CPU time (``/proc/<pid>/stat``).
_STALL_POLL_S = 0.25


def _cpu_ticks(pids) -> int:
    """The CPU time (user + system, in clock ticks) the processes ``pids`` have used, those
    gone counting for nothing."""
    total = 0
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            total += int(fields[11]) + int(fields[12])  # utime, stime (proc(5): fields 14, 15)
        except (OSError, IndexError, ValueError):  # gone, or no /proc
            pass
    return total


def _wait(pool: RenderPool, future):
    """``future``'s result, or :class:`TimeoutError` once ``pool``'s workers have used no CPU
    for :data:`WORKER_STALL_S` while it was awaited."""
    from concurrent.futures import TimeoutError as FutureTimeout

    pids = list(pool.processes())
    ticks, since = _cpu_ticks(pids), time.monotonic()
    while True:
        try:
            return future.result(timeout=_STALL_POLL_S)
        except FutureTimeout:
            now, used = time.monotonic(), _cpu_ticks(pids)
            if used != ticks:
                ticks, since = used, now
            elif now - since >= WORKER_STALL_S:
                raise TimeoutError from None


def _result(job: tuple, future, pool: RenderPool) -> dict[str, bytes]:
    """The files of ``job``: from ``pool``'s worker, or made here when it has none, its worker
    died or is stuck (:data:`WORKER_STALL_S`; the workers are then killed). The files are the
    same either way."""
    from concurrent.futures import CancelledError
    from concurrent.futures.process import BrokenProcessPool

    if future is not None and (future.done() or not pool.stuck):
        try:
            return _wait(pool, future)
        except BrokenProcessPool:
            if not pool.stuck:
                log.warning("a drawing worker died; drawing in the main process instead")
        except CancelledError:  # cancelled by the pool's shutdown after it was stuck
            pass
        except TimeoutError:
            log.warning("the drawing workers used no CPU for %.0f s: stuck; drawing in the main process instead", WORKER_STALL_S)
            pool.stuck = True
            pool.terminate()
    return _call(job)


class _EitherSide:
    """A job (a DXF file: no figure, pure Python) made by whichever of this process and the
    pool's worker is free for it first.

    This process makes it when it comes to it (after the models and the report's page), unless
    the worker finished its last drawing before: then the job was handed to the worker (a
    callback of that drawing's future), which this process waits for. On a large scan this
    process's models and report page outlast the worker's drafting plans, which then takes the
    DXF files (the 3M-face apartment: 0.3 s of the run's end); on a small one this process is
    free first and keeps them. Either way the files are the same.
    """

    def __init__(self, pool: RenderPool, job: tuple, last) -> None:
        import threading

        self.pool, self.job = pool, job
        self.future: Future | None = None  # the worker's, once handed over
        self._lock = threading.Lock()
        self._taken = False
        if last is not None:
            last.add_done_callback(self._hand_over)

    def _hand_over(self, _done) -> None:
        with self._lock:  # (held while submitting: files() then sees the future)
            if self._taken or self.pool.stuck or self.pool.executor is None:
                return
            self._taken = True
            try:
                self.future = self.pool.executor.submit(_call, self.job)
            except Exception as exc:  # the pool broken or shut down: made here (files())
                log.debug("the DXF job stays in the main process (%s)", exc)

    def files(self) -> dict[str, bytes]:
        """The job's files: the worker's when it was handed over, else made here (:func:`_result`
        without a future)."""
        with self._lock:
            self._taken, future = True, self.future
        return _result(self.job, future, self.pool)


def _cad_files(result: Result) -> dict[str, bytes]:
    """The optional IFC and energy models (made in this process)."""
    files: dict[str, bytes] = {}
    if result.options.export.ifc:
        from .ifc import ifc_bytes

        files["model.ifc"] = ifc_bytes(result)
    export = result.options.export
    if export.gbxml or export.idf or export.osm:
        from .energy import energy_files
        from .gbxml import energy_model, gbxml_bytes

        model = energy_model(result)
        gbxml = gbxml_bytes(result, model)
        if export.gbxml:
            files["model.gbxml"] = gbxml
        files.update(energy_files(result, export.idf, export.osm, model, gbxml))
    return files


def _undrawn_files(result: Result, dxf: list[tuple]) -> dict[str, bytes]:
    """The files no figure is drawn for, made in this process: the IFC and energy models, the
    GLB models and the DXF files (the jobs ``dxf``)."""
    files = _cad_files(result)
    for job in _model_jobs(result) + dxf:
        files.update(_call(job))
    return files


@dataclass(frozen=True, eq=False)
class EarlyDrawings:
    """Drawings handed to a pool's workers before the result existed (:func:`submit_early`):
    the jobs and their futures (``None`` where no worker took the job), and the stories'
    sheets once the pen-and-ink plans are among them (every later drawing is on the same)."""

    jobs: list[tuple]
    futures: list
    sheets: tuple[Sheet, ...] | None = None


def submit_early(pool: RenderPool | None, oriented: Oriented, upright: EarlyDrawings | None = None) -> EarlyDrawings | None:
    """Hand the drawings the oriented scan alone decides to the workers of ``pool`` (none
    without workers: :func:`render_files` then draws everything itself): the pen-and-ink plans,
    and the normals and levels unless ``upright`` (:func:`submit_upright`) holds them already
    (then the drawings of both, those of ``upright`` first)."""
    if pool is None or pool.executor is None:
        return None
    sheets = _sheets(oriented)
    if upright is None:
        jobs = _early_jobs(oriented, sheets)
        return EarlyDrawings(jobs, _submit(pool, jobs), sheets)
    jobs = _pen_jobs(oriented, sheets)
    return EarlyDrawings(upright.jobs + jobs, upright.futures + _submit(pool, jobs), sheets)


def submit_walls(pool: RenderPool | None, oriented: Oriented, walls: FlatWalls, early: EarlyDrawings | None) -> EarlyDrawings | None:
    """Hand the wall segments figures (:func:`_segments_jobs`) to the workers of ``pool`` once
    the flat walls are final: the drawings of ``early`` and these (``early`` alone without
    workers or without early drawings)."""
    if pool is None or pool.executor is None or early is None or early.sheets is None:
        return early
    jobs = _segments_jobs(oriented, walls, early.sheets)
    return EarlyDrawings(early.jobs + jobs, early.futures + _submit(pool, jobs), early.sheets)


def submit_upright(pool: RenderPool | None, orientation: Orientation, mesh: Mesh, params: RenderParams) -> EarlyDrawings | None:
    """Hand the drawings the orientation alone decides (:func:`_upright_jobs`) to the workers
    of ``pool``, as soon as the scan is oriented (``None`` without workers)."""
    if pool is None or pool.executor is None:
        return None
    jobs = _upright_jobs(orientation, mesh, params)
    return EarlyDrawings(jobs, _submit(pool, jobs))


def render_files(result: Result, timer: _Timer | None = None, pool: RenderPool | None = None, early: EarlyDrawings | None = None) -> dict[str, bytes]:
    """Every output file except plan.json, as ``name -> bytes``, in a deterministic order.

    The drawings are made by the workers of ``pool`` (one is opened here when none is given and
    ``RenderParams.processes`` asks for workers), those of ``early`` already under way; meanwhile
    this process makes the GLB models, what the report needs of the result and the DXF files
    (none of which draws a figure; the DXF files go to the worker if it is done drawing first:
    :class:`_EitherSide`). Without workers everything is made here. The drawings count
    as the paper's slicing-and-drawing time (``slice_draw``: until the last one is in); the rest
    (models, DXF files, report) as ``write``. The stages follow each other, so that their times
    add up to the wall time.
    """
    from contextlib import ExitStack, nullcontext

    stage = timer.stage if timer else (lambda name: nullcontext())
    files: dict[str, bytes] = {}
    with ExitStack() as stack:
        if pool is None:
            pool = stack.enter_context(RenderPool(_processes(result.options.render)))
        with stage("slice_draw"):
            # the wall segments, when the run handed them over with the early drawings
            segments_done = early is not None and any(job[0] is _segments_files for job in early.jobs)
            # the sheets of the drawings under way (their pen-and-ink plans'), else this result's
            sheets = early.sheets if early is not None and early.sheets is not None else _sheets(result)
            later, dxf = _jobs(result, pool.workers, segments=not segments_done, sheets=sheets)
            if early is None:  # none under way: this result's own
                jobs = _early_jobs(_oriented_of(result), sheets)
                early = EarlyDrawings(jobs, _submit(pool, jobs), sheets)
            elif early.sheets is None:  # the orientation's figures under way, not the pen-and-ink plans
                jobs = _pen_jobs(_oriented_of(result), sheets)
                early = EarlyDrawings(early.jobs + jobs, early.futures + _submit(pool, jobs), sheets)
            # the early ones first (under way, or the slowest: the pen-and-ink plans), then the
            # drafting plans: no worker is left with a long job at the end
            drawings = early.jobs + later
            pending = list(early.futures) + _submit(pool, later)
            parallel = any(f is not None for f in pending)
            page = None
            if parallel:  # the workers draw: make here what needs no drawing
                # the DXF files last: the worker takes them if it is done drawing first
                either = [_EitherSide(pool, job, pending[-1]) for job in dxf]
                files.update(_undrawn_files(result, []))
                page = report_page(result)
                for e in either:
                    files.update(e.files())
            for job, future in zip(drawings, pending):
                files.update(_result(job, future, pool))
        with stage("write"):
            if not parallel:
                files.update(_undrawn_files(result, dxf))
            # last: the report inlines the other files
            files["report.html"] = report_html(result, files, page=page).encode("utf-8")
    return dict(sorted(files.items()))


@dataclass(frozen=True)
class Written:
    """What :func:`write_results` wrote.

    Attributes
    ----------
    output_dir
        The directory, complete.
    files
        Names of the files in it, ``plan.json`` first, then in sorted order.
    timings
        Seconds per stage, as recorded in ``plan.json``: the result's (or the timer's), with
        the drawing (``slice_draw``), ``write`` and, given ``started``, ``total``.
    """

    output_dir: Path
    files: tuple[str, ...]
    timings: dict[str, float] = field(default_factory=dict)


def write_results(
    result: Result,
    outdir: Path,
    force: bool = False,
    timer: _Timer | None = None,
    started: float | None = None,
    pool: RenderPool | None = None,
    early: EarlyDrawings | None = None,
) -> Written:
    """Render and write every output of ``result`` into ``outdir`` (atomically), drawing with
    the workers of ``pool`` when given (``early``: the drawings already handed to them).

    ``result`` is left as it is; the run API makes the final result from what this returns
    (``dataclasses.replace(result, output_dir=..., files=..., timings=...)``).
    """
    files = render_files(result, timer, pool, early)
    t0 = time.perf_counter()
    with staged_directory(outdir, force=force) as tmp:
        for name, data in files.items():
            (tmp / name).write_bytes(data)
        if timer is not None:
            timer.timings["write"] = timer.timings.get("write", 0.0) + time.perf_counter() - t0
            timings = dict(timer.timings)
        else:
            timings = dict(result.timings)
        if started is not None:
            timings["total"] = time.perf_counter() - started
        (tmp / "plan.json").write_text(dumps(plan_document(replace(result, timings=timings))), encoding="utf-8")
    return Written(Path(outdir), ("plan.json", *files), timings)
