"""Many scans in one go: :func:`find_scans` and :func:`run_batch` (``meshplan batch``).

Each scan goes through :func:`meshplan.pipeline.run` on its own, into its own directory under the
batch's output directory; a summary of all of them is written beside those directories as
``summary.csv`` and ``summary.json``.

Design decisions
----------------
Failures stay with their scan
    A scan that fails (unreadable file, no floor, any :class:`~meshplan.errors.MeshplanError`) is
    reported in the summary with its one-line message and the batch goes on. An unexpected
    exception is reported too, as ``unexpected error: <type>: <message>`` (its traceback is kept
    in ``summary.json``), and so is a worker process that dies (killed for lack of memory, a crash
    in compiled code): that scan fails, a new worker takes over the rest.
Nothing written is lost
    Every scan's directory is written atomically by :func:`meshplan.pipeline.run` (complete or
    absent, never half-written); ``summary.csv`` and ``summary.json`` are written atomically at
    the end, and also when the batch is interrupted (unfinished scans are then ``failed`` with
    the error ``interrupted``).
Output layout and re-runs
    The output directory may exist already: it is a container, and the batch adds to it. One
    directory per scan is created in it, named after the scan file's stem. Scans with equal stems
    (``a/scan.obj`` and ``b/scan.obj``, as ``meshplan synth`` writes them) are told apart by as
    many parent directories as needed (``a-scan``, ``b-scan``), then by the extension
    (``scan-obj``, ``scan-ply``), then by ``-2``, ``-3`` in input order. Names depend only on the
    set of inputs, never on timing. A scan whose directory exists already is refused unless
    ``force``: that *scan* is reported as failed (``... already exists; pass --force ...``), not
    the whole batch, and its previous result is left untouched. With ``force`` every scan's
    directory is replaced atomically, so re-running a batch with ``--force`` redoes it all.
    ``summary.csv`` and ``summary.json`` always describe the latest run and are replaced.
Discovery
    A directory is searched recursively for files with a mesh extension
    (:data:`meshplan.io.MESH_FORMATS`, any case), skipping hidden files and directories and the
    batch's own output directory (its ``*.glb`` models would otherwise be taken for scans).
    ``<stem>.annotations.json`` beside a scan, else ``annotations.json`` beside it, is used as
    its annotations.
Parallelism is across scans
    Each scan draws its plans in its own worker (the pipeline's ``processes`` option is set to
    1 unless given, e.g. ``--set processes=2``): on 2 cores, drawing one scan with 2 processes
    saves about 10 %, running 2 scans at once almost 50 %, and both at once would oversubscribe
    the cores. The same value is used locally and on Dask, so ``plan.json`` (which records every
    parameter) does not depend on how the batch ran.
Local parallelism
    ``workers > 1`` starts that many worker processes, each importing the pipeline once and
    taking one scan at a time from the parent until none is left (dynamic scheduling: a slow
    scan does not hold the others up). Processes are started with ``spawn`` (see
    :data:`START_METHOD` for the measurements behind that choice) with OpenMP/BLAS/numba thread
    pools limited to one thread each (unless the user's environment sets them), so that N
    workers use N cores and do not oversubscribe them. ``workers=1`` runs in this process.
    ``spawn`` re-imports the caller's ``__main__`` in each worker: a script calling
    :func:`run_batch` with ``workers > 1`` needs the usual ``if __name__ == "__main__":`` guard.
Dask
    ``scheduler="tcp://host:port"`` sends the same per-scan function to an existing Dask
    distributed cluster (imported lazily; it is the ``meshplan[dask]`` extra). The workers read
    scans and write results *by path*: every worker must see the same file system at the same
    absolute paths (a shared file system), and must have meshplan installed. Dask's nanny
    already limits each worker's BLAS/OpenMP threads to one.
Paths
    Workers get absolute paths (so the same batch gives the same ``plan.json`` locally and on a
    cluster, whose workers may run in other directories); the summary shows paths as given.
"""

from __future__ import annotations

import contextlib
import csv
import fnmatch
import glob
import io
import json
import logging
import multiprocessing
import os
import sys
import time
import traceback
import uuid
import warnings
from collections import deque
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import MeshplanError, OutputError, ParameterError
from .io import MESH_FORMATS, atomic_write_text

log = logging.getLogger("meshplan")

#: Columns of ``summary.csv`` (``summary.json`` has these and a few more per scan).
SUMMARY_COLUMNS = ("scan", "output", "status", "error", "stories", "walls", "rooms", "area_m2", "faces", "time_s")

#: Names of the summary files written into the batch's output directory.
SUMMARY_FILES = ("summary.csv", "summary.json")

#: How local worker processes are started (``MESHPLAN_START_METHOD`` overrides it). Measured with
#: ``benchmarks/bench_batch.py`` on a 2-core machine (20 room scans, 2 workers): spawn, fork and
#: forkserver differ by less than the run-to-run noise (well under a second of a ~30 s batch)
#: because each worker imports the pipeline once and then handles many scans, so start-up is
#: paid once per worker. ``spawn`` is chosen as it is safe whatever the parent holds (``fork``
#: copies the parent's threads and locks, e.g. the progress bar's refresh thread and BLAS pools)
#: and each worker starts with the thread limits below in its environment before numpy loads.
START_METHOD = "spawn"

#: Thread pools limited to one thread in each local worker, unless the environment sets them:
#: N single-threaded workers on N cores beat N workers each starting N threads.
THREAD_ENV = (
    "OMP_NUM_THREADS",
    "OPENBLAS_NUM_THREADS",
    "MKL_NUM_THREADS",
    "VECLIB_MAXIMUM_THREADS",
    "NUMEXPR_NUM_THREADS",
    "NUMBA_NUM_THREADS",
)

_MAX_ERROR_CHARS = 400


class ScansFailed(MeshplanError):
    """Some scans of a batch failed (``meshplan batch`` exits with status 1)."""

    exit_code = 1


class BatchInterrupted(MeshplanError):
    """The batch was interrupted (``meshplan batch`` exits with status 130)."""

    exit_code = 130


# --------------------------------------------------------------------------------------------
# Finding scans


def _mesh_file(path: Path) -> bool:
    return path.suffix.lower() in MESH_FORMATS


def _formats() -> str:
    return ", ".join(sorted(MESH_FORMATS))


def _inside(path: Path, folder: Path | None) -> bool:
    if folder is None:
        return False
    try:
        return Path(os.path.abspath(path)).is_relative_to(Path(os.path.abspath(folder)))
    except (OSError, ValueError):
        return False


def _excluded(path: Path, patterns: Sequence[str]) -> bool:
    """Whether ``path`` matches one of the glob ``patterns``, by its file name
    (``*.su_planes.ply``) or by its whole path (``*/old/*``)."""
    text = path.as_posix()
    return any(fnmatch.fnmatch(path.name, pat) or fnmatch.fnmatch(text, pat) for pat in patterns)


def find_scans(
    spec: str | os.PathLike, *, exclude: str | os.PathLike | None = None, skip: Sequence[str] = ()
) -> list[Path]:
    """The scan files a batch input names.

    Parameters
    ----------
    spec
        A directory (searched recursively for files with a mesh extension, hidden files and
        directories skipped), a glob pattern (``**`` allowed; only files with a mesh extension
        are kept), or a single mesh file.
    exclude
        A directory whose contents are never taken as scans (the batch's output directory).
    skip
        Glob patterns of files that are not scans although they have a mesh extension, matched
        against the file name or the path (e.g. ``*.su_planes.ply``, the HoloLens 2 plane
        sidecars).

    Returns
    -------
    list of Path
        The scans, sorted (a glob's matches and a directory's files both in path order), as
        paths relative to the same place as ``spec``.

    Raises
    ------
    MeshplanError
        When nothing matches (one line: the problem; what to do).
    """
    text = os.fspath(spec)
    path = Path(text)
    excl = Path(exclude) if exclude is not None else None
    if path.is_dir():
        found: list[Path] = []
        for root, dirs, files in os.walk(path):
            # skip hidden directories (e.g. half-written results) and the batch's own output
            dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not _inside(Path(root, d), excl))
            found.extend(Path(root, f) for f in files if not f.startswith(".") and _mesh_file(Path(f)))
        found = sorted(p for p in found if not _inside(p, excl) and not _excluded(p, skip))
        if not found:
            raise MeshplanError(
                f"{text}: no scan files ({_formats()}) in this directory or below",
                "put the scans in it, or give a glob pattern such as 'scans/**/*.ply'",
            )
        return found
    if path.is_file():
        if _excluded(path, skip):
            return []
        if not _mesh_file(path):
            raise MeshplanError(f"{text}: not a mesh file ({_formats()})", "give a directory of scans, a glob pattern or a mesh file")
        return [path]
    if glob.has_magic(text):
        matches = sorted({Path(m) for m in glob.glob(text, recursive=True)})
        found = [p for p in matches if p.is_file() and _mesh_file(p) and not _inside(p, excl) and not _excluded(p, skip)]
        if not found:
            what = f"matches {len(matches)} files but none is a scan ({_formats()})" if matches else "matches no file"
            raise MeshplanError(f"{text!r} {what}", "check the pattern (quote it so that the shell does not expand it)")
        return found
    raise MeshplanError(f"{text}: no such directory or file", "give a directory of scans or a glob pattern such as 'scans/**/*.obj'")


#: Where a scan's annotations are looked for when no pattern is given, in this order.
DEFAULT_ANNOTATION_PATTERNS = ("{stem}.annotations.json", "annotations.json")


def find_annotations(scan: str | os.PathLike, pattern: str | None = None) -> Path | None:
    """The annotations of a scan.

    Parameters
    ----------
    scan
        The scan file.
    pattern
        A file name or path relative to the scan's directory in which ``{stem}`` stands for the
        scan's file name without its extension (``{stem}-sensors.json``, ``../ann/{stem}.json``).
        ``None``: ``<stem>.annotations.json`` beside the scan, else ``annotations.json``.

    Returns
    -------
    Path or None
        The first candidate that is a file, or ``None``.
    """
    p = Path(scan)
    patterns = DEFAULT_ANNOTATION_PATTERNS if pattern is None else (pattern,)
    for candidate in (p.parent / pat.replace("{stem}", p.stem) for pat in patterns):
        if candidate.is_file():
            return candidate
    return None


def output_names(scans: Sequence[str | os.PathLike]) -> list[str]:
    """One distinct directory name per scan, from the file names (see the module docstring).

    Deterministic: depends only on the list. Names are compared case-insensitively (for
    case-insensitive file systems) and never equal a summary file's name.
    """
    paths = [Path(os.path.abspath(s)) for s in scans]

    def name(p: Path, depth: int, ext: bool = False) -> str:
        parents = [q for q in p.parent.parts if q not in ("/", p.anchor)]
        parts = [*parents[len(parents) - depth :]] if depth else []
        stem = p.stem.lstrip(".") or "scan"  # a leading dot would hide the directory
        parts.append(f"{stem}-{p.suffix.lstrip('.').lower()}" if ext else stem)
        return "-".join(s.replace(os.sep, "-") for s in parts)

    names = [name(p, 0) for p in paths]
    groups: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        groups.setdefault(n.casefold(), []).append(i)
    for members in groups.values():
        if len(members) < 2:
            continue
        # fewest parent directories that tell the group's scans apart
        deepest = max(len(paths[i].parent.parts) for i in members)
        depth = next(
            (d for d in range(1, deepest + 1) if len({name(paths[i], d).casefold() for i in members}) == len(members)),
            deepest,
        )
        cand = {i: name(paths[i], depth) for i in members}
        counts: dict[str, int] = {}
        for n in cand.values():
            counts[n.casefold()] = counts.get(n.casefold(), 0) + 1
        for i in members:
            # same directory and stem: the extension tells them apart
            names[i] = name(paths[i], depth, ext=True) if counts[cand[i].casefold()] > 1 else cand[i]
    # whatever still collides (the same file twice, a name made equal to another): -2, -3, ...
    taken = {f.casefold() for f in SUMMARY_FILES}
    out: list[str] = []
    for n in names:
        unique, k = n, 1
        while unique.casefold() in taken:
            k += 1
            unique = f"{n}-{k}"
        taken.add(unique.casefold())
        out.append(unique)
    return out


# --------------------------------------------------------------------------------------------
# One scan (runs in a worker)


def _one_line(text: str) -> str:
    line = " ".join(str(text).split())
    return line if len(line) <= _MAX_ERROR_CHARS else line[: _MAX_ERROR_CHARS - 3] + "..."


class _LogCapture(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.messages: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(Exception):
            self.messages.append(_one_line(f"{record.name}: {record.getMessage()}"))


@contextlib.contextmanager
def _captured() -> Iterator[tuple[list, _LogCapture]]:
    """Collect Python warnings and log warnings instead of printing them: they would tear the
    progress bar apart, and they belong to their scan's row in ``summary.json``."""
    handler = _LogCapture()
    root = logging.getLogger()
    root.addHandler(handler)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")  # per scan, not once per long-lived worker
            warnings.filterwarnings("ignore", category=DeprecationWarning)
            warnings.filterwarnings("ignore", category=PendingDeprecationWarning)
            yield caught, handler
    finally:
        root.removeHandler(handler)


def process_scan(scan: str, annotations: str | None, output: str, options: Any, force: bool = False) -> dict[str, Any]:
    """Run the pipeline on one scan and describe the outcome; never raises for a bad scan.

    This is what every worker runs (locally or on Dask), so it takes and returns only small,
    picklable values: the :class:`~meshplan.pipeline.Result` (with its mesh) stays in the worker.

    Parameters
    ----------
    scan, annotations, output
        Absolute paths of the scan, its annotations (or ``None``) and its output directory.
    options
        The :class:`~meshplan.options.RunOptions` of every scan.
    force
        Replace an existing output directory.

    Returns
    -------
    dict
        ``status`` (``ok`` or ``failed``), ``error`` (one line, empty when ok), ``stories``,
        ``walls``, ``rooms``, ``area_m2``, ``faces`` (``None`` when failed), ``time_s`` (wall
        clock), ``cpu_s`` (CPU time of the worker process), ``warnings`` and, for unexpected errors, ``traceback``.
    """
    from . import pipeline

    t0, c0 = time.perf_counter(), time.process_time()
    out: dict[str, Any] = {"status": "failed", "error": "", "stories": None, "walls": None, "rooms": None,
                           "area_m2": None, "faces": None, "warnings": []}
    with _captured() as (caught, logs):
        try:
            result = pipeline.run(scan, annotations=annotations, output=output, force=force, options=options)
            from .export.planjson import plan_document

            # rooms come from plan.json, which may or may not have them yet
            rooms = plan_document(result).get("rooms", []) or []
            out.update(
                status="ok",
                stories=len(result.stories),
                walls=len(result.walls),
                rooms=len(rooms),
                area_m2=round(float(sum(float(r.get("area", 0.0) or 0.0) for r in rooms)), 3),
                faces=int(result.input.faces),
            )
            out["warnings"].extend(result.warnings)
        except MeshplanError as exc:
            out["error"] = _one_line(exc.message)
        except Exception as exc:  # a bug: report it with its scan and go on with the others
            out["error"] = _one_line(f"unexpected error: {type(exc).__name__}: {exc} (a bug in meshplan; traceback in summary.json)")
            out["traceback"] = traceback.format_exc()
    out["warnings"].extend(_one_line(f"{w.category.__name__}: {w.message}") for w in caught)
    out["warnings"].extend(logs.messages)
    out["warnings"] = list(dict.fromkeys(str(w) for w in out["warnings"]))
    out["time_s"] = round(time.perf_counter() - t0, 3)
    # CPU seconds of this process (all its threads): well below time_s means CPU-starved
    out["cpu_s"] = round(time.process_time() - c0, 3)
    return out


# --------------------------------------------------------------------------------------------
# Summary


@dataclass
class ScanRow:
    """One scan's line of the batch summary.

    Attributes
    ----------
    scan
        The scan's path, as given.
    output
        The directory assigned to the scan (written by this run only when ``status`` is ``ok``).
    status
        ``ok`` or ``failed``.
    error
        One-line message of a failed scan, empty otherwise.
    stories, walls, rooms, faces
        Counts (``None`` for a failed scan).
    area_m2
        Sum of the rooms' floor areas, 0 when no room was found (``None`` for a failed scan).
    time_s
        Seconds the scan took in its worker.
    cpu_s
        CPU seconds the worker spent on it (only in ``summary.json``).
    annotations
        The annotations file used, if any.
    warnings
        Warnings of the run (only in ``summary.json``).
    traceback
        The traceback of an unexpected error (only in ``summary.json``).
    """

    scan: str
    output: str
    status: str
    error: str = ""
    stories: int | None = None
    walls: int | None = None
    rooms: int | None = None
    area_m2: float | None = None
    faces: int | None = None
    time_s: float = 0.0
    cpu_s: float | None = None
    annotations: str | None = None
    warnings: list[str] = field(default_factory=list)
    traceback: str | None = None

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict[str, Any]:
        d = {c: getattr(self, c) for c in SUMMARY_COLUMNS}
        d["cpu_s"] = self.cpu_s
        d["annotations"] = self.annotations
        d["warnings"] = list(self.warnings)
        if self.traceback:
            d["traceback"] = self.traceback
        return d


@dataclass
class BatchSummary:
    """What :func:`run_batch` did, one :class:`ScanRow` per scan in input order.

    Attributes
    ----------
    output
        The batch's output directory.
    rows
        One per scan, in input order.
    workers
        Local worker processes (1 = this process; 0 on a Dask cluster).
    scheduler
        The Dask scheduler's address, or ``None``.
    wall_time_s
        Seconds for the whole batch.
    interrupted
        The batch was stopped before every scan was done.
    """

    output: Path
    rows: list[ScanRow]
    workers: int = 1
    scheduler: str | None = None
    wall_time_s: float = 0.0
    interrupted: bool = False

    @property
    def ok(self) -> list[ScanRow]:
        return [r for r in self.rows if r.ok]

    @property
    def failed(self) -> list[ScanRow]:
        return [r for r in self.rows if not r.ok]

    @property
    def exit_code(self) -> int:
        """0 when every scan succeeded, 1 otherwise (as ``meshplan batch`` exits)."""
        return 0 if self.rows and not self.failed else 1

    def to_dict(self) -> dict[str, Any]:
        return {
            "output": str(self.output),
            "scans": len(self.rows),
            "ok": len(self.ok),
            "failed": len(self.failed),
            "interrupted": self.interrupted,
            "workers": self.workers,
            "scheduler": self.scheduler,
            "wall_time_s": round(self.wall_time_s, 3),
            "columns": list(SUMMARY_COLUMNS),
            "rows": [r.to_dict() for r in self.rows],
        }

    def csv_text(self) -> str:
        buf = io.StringIO()
        w = csv.writer(buf, lineterminator="\n")
        w.writerow(SUMMARY_COLUMNS)
        for r in self.rows:
            w.writerow(["" if getattr(r, c) is None else getattr(r, c) for c in SUMMARY_COLUMNS])
        return buf.getvalue()

    def write(self) -> None:
        """Write ``summary.csv`` and ``summary.json`` into the output directory, atomically."""
        atomic_write_text(self.output / "summary.csv", self.csv_text())
        atomic_write_text(self.output / "summary.json", json.dumps(self.to_dict(), indent=2) + "\n")


# --------------------------------------------------------------------------------------------
# Local worker processes


@contextlib.contextmanager
def _single_threaded_env() -> Iterator[None]:
    """Set the thread-pool variables (where unset) while child processes are started, so each
    starts with them before it imports numpy; the parent's environment is restored after."""
    added = [k for k in THREAD_ENV if k not in os.environ]
    for k in added:
        os.environ[k] = "1"
    try:
        yield
    finally:
        for k in added:
            os.environ.pop(k, None)


def _limit_threads() -> None:
    for k in THREAD_ENV:
        os.environ.setdefault(k, "1")
    if "numpy" in sys.modules:  # inherited by fork with pools already sized
        with contextlib.suppress(Exception):
            from threadpoolctl import threadpool_limits

            threadpool_limits(1)


def _worker_main(conn: Any, func: Callable[..., dict[str, Any]]) -> None:
    """A local worker: run ``func(*args)`` for each ``(index, args)`` received, until ``None``."""
    _limit_threads()
    logging.getLogger().setLevel(logging.WARNING)
    try:
        while True:
            msg = conn.recv()
            if msg is None:
                break
            index, args = msg
            conn.send((index, func(*args)))
    except (KeyboardInterrupt, EOFError, BrokenPipeError):
        pass  # the parent is stopping the batch; say nothing


@dataclass(eq=False)
class _Worker:
    process: Any
    conn: Any
    job: int | None = None


def _died(exitcode: int | None) -> str:
    import signal

    if exitcode is not None and exitcode < 0:
        with contextlib.suppress(ValueError):
            how = f"killed by {signal.Signals(-exitcode).name}"
            return f"the worker process died ({how}; out of memory?) while processing this scan; run it alone with 'meshplan run' to see why"
    return f"the worker process died (exit status {exitcode}) while processing this scan; run it alone with 'meshplan run' to see why"


def _run_local(
    tasks: Sequence[tuple],
    workers: int,
    func: Callable[..., dict[str, Any]],
    on_done: Callable[[int, dict[str, Any]], None],
    start_method: str | None = None,
) -> None:
    """Run ``func(*task)`` for every task on ``workers`` processes; ``on_done(index, outcome)``
    is called in this process as each finishes (in completion order).

    Each worker gets one task at a time, so a crashed worker is known to have crashed on that
    task: it is reported failed and a new worker takes the remaining tasks.
    """
    from multiprocessing.connection import wait

    ctx = multiprocessing.get_context(start_method or os.environ.get("MESHPLAN_START_METHOD") or START_METHOD)
    pending = deque(range(len(tasks)))
    pool: list[_Worker] = []

    def start() -> _Worker:
        parent, child = ctx.Pipe()
        with _single_threaded_env():
            # not daemonic: a scan may draw with processes > 1 (forked children); stopped in finally
            # typeshed's get_context(str) gives BaseContext, which lacks Process; every concrete context has it
            p = ctx.Process(target=_worker_main, args=(child, func), name="meshplan-batch-worker", daemon=False)  # type: ignore[attr-defined]
            p.start()
        child.close()
        w = _Worker(p, parent)
        pool.append(w)
        return w

    def dispatch(w: _Worker) -> None:
        w.job = None
        if not pending:
            with contextlib.suppress(OSError):
                w.conn.send(None)
            return
        i = pending.popleft()
        try:
            w.conn.send((i, tasks[i]))
            w.job = i
        except OSError:  # the worker is gone; the task goes to its replacement
            pending.appendleft(i)
            _retire(w)
            dispatch(start())

    def _retire(w: _Worker) -> None:
        with contextlib.suppress(Exception):
            w.conn.close()
        w.process.join(timeout=5)
        if w.process.is_alive():
            w.process.terminate()
        pool.remove(w)

    try:
        for _ in range(min(workers, len(tasks))):
            dispatch(start())
        while True:
            busy = [w for w in pool if w.job is not None]
            if not busy:
                break
            ready = wait([w.conn for w in busy] + [w.process.sentinel for w in busy])
            for w in busy:
                if w.conn not in ready and w.process.sentinel not in ready:
                    continue
                index = w.job
                assert index is not None  # busy workers have a job
                outcome = None
                try:
                    # a result sent just before the worker exited is still in the pipe
                    if w.conn.poll():
                        _, outcome = w.conn.recv()
                except (EOFError, OSError):
                    outcome = None  # the pipe closed: the worker is dead or dying
                if outcome is not None:
                    on_done(index, outcome)
                    dispatch(w)
                    continue
                w.process.join(timeout=5)
                on_done(index, {"status": "failed", "error": _died(w.process.exitcode)})
                _retire(w)
                if pending:
                    dispatch(start())
        for w in list(pool):
            _retire(w)
    finally:
        for w in pool:  # interrupted or failed: stop every worker now
            with contextlib.suppress(Exception):
                w.process.terminate()
        for w in pool:
            with contextlib.suppress(Exception):
                w.process.join(timeout=5)
                w.conn.close()


# --------------------------------------------------------------------------------------------
# Dask


def _dask_client(address: str) -> Any:
    try:
        import distributed
    except ImportError:
        raise MeshplanError(
            "--scheduler needs Dask distributed, which is not installed",
            "pip install 'meshplan[dask]' (or pip install 'dask[distributed]')",
        ) from None
    try:
        return distributed.Client(address, timeout="15s", set_as_default=False)
    except Exception as exc:  # OSError, TimeoutError, ValueError for a malformed address, ...
        raise MeshplanError(
            f"cannot connect to the Dask scheduler at {address!r} ({_one_line(str(exc)) or type(exc).__name__})",
            "check the address (tcp://host:port) and that the scheduler is running",
        ) from None


def _run_dask(
    tasks: Sequence[tuple],
    client: Any,
    func: Callable[..., dict[str, Any]],
    on_done: Callable[[int, dict[str, Any]], None],
    names: Sequence[str],
) -> None:
    """Run ``func(*task)`` for every task on the cluster of ``client`` (closed at the end);
    ``on_done(index, outcome)`` is called in this process as each finishes."""
    import distributed

    with client:
        batch_id = uuid.uuid4().hex[:8]
        futures = {
            client.submit(func, *task, key=f"meshplan-{batch_id}-{i}-{names[i]}", pure=False, retries=0): i
            for i, task in enumerate(tasks)
        }
        try:
            # this client is not the default one (set_as_default=False): give its loop
            for fut in distributed.as_completed(list(futures), loop=client.loop):
                i = futures[fut]
                try:
                    outcome = fut.result()
                except Exception as exc:  # the task never ran to the end (a dead worker, no meshplan there, ...)
                    outcome = {
                        "status": "failed",
                        "error": _one_line(
                            f"the Dask task failed ({type(exc).__name__}: {exc}); "
                            "check that meshplan is installed on the workers and that they have enough memory"
                        ),
                    }
                on_done(i, outcome)
        finally:
            with contextlib.suppress(Exception):
                client.cancel([f for f in futures if not f.done()])


# --------------------------------------------------------------------------------------------
# The batch

Progress = Callable[[int, int, "ScanRow | None"], None]  # (done, total, row just finished or None)
Inputs = str | os.PathLike | Iterable[str | os.PathLike | tuple[str | os.PathLike, str | os.PathLike | None]]


def _jobs(inputs: Inputs, output: Path) -> list[tuple[Path, Path | None]]:
    if isinstance(inputs, (str, os.PathLike)):
        return [(p, find_annotations(p)) for p in find_scans(inputs, exclude=output)]
    jobs: list[tuple[Path, Path | None]] = []
    for item in inputs:
        if isinstance(item, tuple):
            scan, ann = item
            jobs.append((Path(scan), Path(ann) if ann is not None else None))
        else:
            jobs.append((Path(item), find_annotations(item)))
    if not jobs:
        raise MeshplanError("no scans to process", "give a directory of scans or a glob pattern")
    return jobs


def _prepare_output(output: Path) -> None:
    if output.exists() and not output.is_dir():
        raise OutputError(f"{output}: exists and is not a directory", "choose another output directory with -o")
    try:
        output.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{output}: cannot be created ({exc.strerror})", "choose a writable output directory with -o") from None
    if not os.access(output, os.W_OK | os.X_OK):
        raise OutputError(f"{output}: cannot be written", "choose a writable output directory with -o")


def run_batch(
    inputs: Inputs,
    output: str | os.PathLike,
    *,
    workers: int = 1,
    scheduler: str | None = None,
    force: bool = False,
    progress: Progress | None = None,
    **params: Any,
) -> BatchSummary:
    """Run the pipeline on many scans, one output directory each, and summarize.

    Parameters
    ----------
    inputs
        A directory or glob pattern (see :func:`find_scans`; annotations are found with
        :func:`find_annotations`), or a list of scan paths, or of ``(scan, annotations)`` pairs.
    output
        The batch's directory: one directory per scan in it (see :func:`output_names`), plus
        ``summary.csv`` and ``summary.json``. It may exist (the batch adds to it).
    workers
        Local worker processes (1 = in this process; 0 = one per available core).
    scheduler
        Address of a Dask distributed scheduler (``tcp://host:port``) to run the scans on
        instead; the workers must share this file system (same absolute paths) and have
        meshplan installed.
    force
        Replace existing per-scan directories (atomically). Without it a scan whose directory
        exists is reported as failed and its old result kept.
    progress
        Called as ``progress(done, total, row)``: once with ``row=None`` before the first scan,
        then after each scan (in completion order).
    **params
        Run options, as for :func:`meshplan.pipeline.run` (``units="cm"``, ``slices=50``, ...);
        checked before any scan starts. ``processes`` (drawing processes per scan) defaults to 1.

    Returns
    -------
    BatchSummary
        Rows in input order; also written as ``summary.csv`` and ``summary.json``.

    Raises
    ------
    MeshplanError
        Before any scan is processed: no scans found, bad options, an output directory that
        cannot be written, no Dask or no scheduler at ``scheduler``. A failing scan never raises.
    """
    from .options import RunOptions

    t0 = time.perf_counter()
    out = Path(output)
    if scheduler is not None and workers != 1:
        raise ParameterError("--workers and --scheduler cannot be combined", "the Dask cluster decides how many scans run at once")
    if not isinstance(workers, int) or isinstance(workers, bool) or workers < 0:
        raise ParameterError(f"workers must be a whole number >= 0, got {workers!r}", "pass --workers N")
    if workers == 0:
        workers = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    if "processes" in RunOptions.names():
        params.setdefault("processes", 1)  # parallel across scans, not within one (module docstring)
    options = RunOptions.from_kwargs(**params)  # a bad option fails the batch, not every scan
    jobs = _jobs(inputs, out)
    # connect before writing anything: a batch refused for want of a cluster leaves no trace
    client = _dask_client(scheduler) if scheduler is not None else None
    try:
        _prepare_output(out)
    except BaseException:
        if client is not None:
            client.close()
        raise
    names = output_names([scan for scan, _ in jobs])
    tasks = [
        (os.path.abspath(scan), os.path.abspath(ann) if ann is not None else None, os.path.abspath(out / name), options, force)
        for (scan, ann), name in zip(jobs, names)
    ]
    rows: list[ScanRow | None] = [None] * len(jobs)
    done = 0

    def on_done(i: int, outcome: dict[str, Any]) -> None:
        nonlocal done
        scan, ann = jobs[i]
        rows[i] = ScanRow(
            scan=str(scan),
            output=str(out / names[i]),
            status="ok" if outcome.get("status") == "ok" else "failed",
            error=str(outcome.get("error") or ""),
            **{k: outcome.get(k) for k in ("stories", "walls", "rooms", "area_m2", "faces")},
            annotations=str(ann) if ann is not None else None,
            time_s=float(outcome.get("time_s") or 0.0),
            cpu_s=outcome.get("cpu_s"),
            warnings=list(outcome.get("warnings") or []),
            traceback=outcome.get("traceback"),
        )
        done += 1
        if progress is not None:
            progress(done, len(jobs), rows[i])

    summary = BatchSummary(out, [], workers=0 if scheduler else workers, scheduler=scheduler)
    if progress is not None:
        progress(0, len(jobs), None)
    try:
        if scheduler is not None:
            _run_dask(tasks, client, process_scan, on_done, names)
        elif workers == 1 or len(tasks) == 1:
            for i, task in enumerate(tasks):
                on_done(i, process_scan(*task))
        else:
            _run_local(tasks, workers, process_scan, on_done)
    except BaseException:
        # interrupted (or the cluster went away): keep a summary of what was done
        summary.interrupted = True
        raise
    finally:
        summary.rows = [
            r if r is not None else ScanRow(str(s), str(out / n), "failed", "interrupted", annotations=str(a) if a else None)
            for r, (s, a), n in zip(rows, jobs, names)
        ]
        summary.wall_time_s = time.perf_counter() - t0
        try:
            summary.write()
        except OSError as exc:
            if not summary.interrupted:  # else the interruption is the news
                raise OutputError(f"{out}: cannot write the summary ({exc.strerror})", "check the free space and permissions") from None
    return summary


# --------------------------------------------------------------------------------------------
# Terminal display


class BatchProgress:
    """An overall progress bar, a line per finished scan (rich, stderr); does nothing when
    disabled or when stderr is not a terminal. Pass its :meth:`update` as ``progress``."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._progress: Any = None
        self._task: Any = None
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> BatchProgress:
        if self.enabled:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

            self._progress = Progress(
                TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(), TimeRemainingColumn(),
                console=Console(stderr=True), refresh_per_second=4,  # keep the parent's CPU for the workers
            )
            from .progress import logs_above_live_display

            self._stack.enter_context(self._progress)
            self._stack.enter_context(logs_above_live_display())  # log lines above the bar, not through it
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stack.__exit__(*exc)

    def update(self, done: int, total: int, row: ScanRow | None) -> None:
        if self._progress is None:
            return
        if self._task is None:
            self._task = self._progress.add_task("Scans", total=total)
        if row is not None:
            from rich.markup import escape

            if row.ok:
                line = f"[green]ok[/]     {escape(row.scan)} -> {escape(row.output)} ({row.time_s:.1f} s)"
            else:
                line = f"[red]failed[/] {escape(row.scan)}: {escape(row.error)}"
            self._progress.console.print(line, highlight=False)
        self._progress.update(self._task, completed=done)


def print_batch_summary(summary: BatchSummary, console: Any = None) -> None:
    """The summary table, then one line per failed scan (rich, stderr by default)."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    console = console or Console(stderr=True)
    table = Table(title=f"Batch: {len(summary.rows)} scans", show_edge=False)
    table.add_column("scan", overflow="fold", ratio=1)
    table.add_column("status", no_wrap=True)
    for col in ("stories", "walls", "rooms", "area m²", "faces", "time s"):
        table.add_column(col, justify="right", no_wrap=True)
    for r in summary.rows:
        if r.ok:
            cells = [str(r.stories), str(r.walls), str(r.rooms), f"{r.area_m2:.2f}", f"{r.faces:,}"]
            table.add_row(escape(r.scan), "[green]ok[/]", *cells, f"{r.time_s:.1f}")
        else:
            table.add_row(escape(r.scan), "[red]failed[/]", "", "", "", "", "", f"{r.time_s:.1f}")
    console.print(table)
    for r in summary.failed:
        console.print(f"[red]failed[/] {escape(r.scan)}: {escape(r.error)}", highlight=False)
    where = summary.scheduler or (f"{summary.workers} workers" if summary.workers > 1 else "1 process")
    console.print(
        f"{len(summary.ok)} ok, {len(summary.failed)} failed in {summary.wall_time_s:.1f} s ({where}); "
        f"results in {escape(str(summary.output))}/<scan>, summary in summary.csv and summary.json there",
        highlight=False,
    )
