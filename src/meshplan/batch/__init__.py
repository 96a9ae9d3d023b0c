"""Many scans in one go: :func:`find_scans` and :func:`run_batch` (``meshplan batch``).

Each scan goes through :func:`meshplan.api.run` on its own, into its own directory under the
batch's output directory; a summary of all of them is written beside those directories as
``summary.csv`` and ``summary.json``.

The package: :mod:`~meshplan.batch.discover` (scans, annotations, output names),
:mod:`~meshplan.batch.worker` (one scan), :mod:`~meshplan.batch.summary` (the summary files),
:mod:`~meshplan.batch.local` (local worker processes), :mod:`~meshplan.batch.dask` (a Dask
cluster); :func:`run_batch` here puts them together. The terminal display is in
:mod:`meshplan.progress` (:class:`~meshplan.progress.BatchProgress`).

Design decisions
----------------
Failures stay with their scan
    A scan that fails (unreadable file, no floor, any :class:`~meshplan.errors.MeshplanError`) is
    reported in the summary with its one-line message and the batch goes on. An unexpected
    exception is reported too, as ``unexpected error: <type>: <message>`` (its traceback is kept
    in ``summary.json``), and so is a worker process that dies (killed for lack of memory, a crash
    in compiled code): that scan fails, a new worker takes over the rest.
Nothing written is lost
    Every scan's directory is written atomically by :func:`meshplan.api.run` (complete or
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

import os
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from ..errors import MeshplanError, OutputError, ParameterError
from ..progress import BatchProgress, print_batch_summary
from .dask import _dask_client, _run_dask
from .discover import DEFAULT_ANNOTATION_PATTERNS, find_annotations, find_scans, output_names
from .local import START_METHOD, _run_local
from .summary import SUMMARY_COLUMNS, SUMMARY_FILES, BatchSummary, ScanRow
from .worker import THREAD_ENV, process_scan

# the private helpers of the one-module meshplan.batch, still importable from here
from .discover import _excluded as _excluded  # isort: skip
from .discover import _formats as _formats  # isort: skip
from .discover import _inside as _inside  # isort: skip
from .discover import _mesh_file as _mesh_file  # isort: skip
from .local import _died as _died  # isort: skip
from .local import _Worker as _Worker  # isort: skip
from .local import _worker_main as _worker_main  # isort: skip
from .worker import _MAX_ERROR_CHARS as _MAX_ERROR_CHARS  # isort: skip
from .worker import _captured as _captured  # isort: skip
from .worker import _limit_threads as _limit_threads  # isort: skip
from .worker import _LogCapture as _LogCapture  # isort: skip
from .worker import _one_line as _one_line  # isort: skip
from .worker import _single_threaded_env as _single_threaded_env  # isort: skip

__all__ = [
    "DEFAULT_ANNOTATION_PATTERNS",
    "START_METHOD",
    "SUMMARY_COLUMNS",
    "SUMMARY_FILES",
    "THREAD_ENV",
    "BatchInterrupted",
    "BatchProgress",
    "BatchSummary",
    "ScanRow",
    "ScansFailed",
    "find_annotations",
    "find_scans",
    "output_names",
    "print_batch_summary",
    "process_scan",
    "run_batch",
]

class ScansFailed(MeshplanError):
    """Some scans of a batch failed (``meshplan batch`` exits with status 1)."""

    exit_code = 1


class BatchInterrupted(MeshplanError):
    """The batch was interrupted (``meshplan batch`` exits with status 130)."""

    exit_code = 130


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
        Run options, as for :func:`meshplan.api.run` (``units="cm"``, ``slices=50``, ...);
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
    from ..options import RunOptions

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
