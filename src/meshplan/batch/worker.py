"""One scan of a batch, as every worker runs it (locally or on Dask): :func:`process_scan`, with
its warnings and log records captured for the summary, and the thread limits of local workers."""

from __future__ import annotations

import contextlib
import logging
import os
import sys
import time
import traceback
import warnings
from collections.abc import Iterator
from typing import Any

from ..errors import MeshplanError

__all__ = ["THREAD_ENV", "process_scan"]

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
    picklable values: the :class:`~meshplan.result.Result` (with its mesh) stays in the worker.

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
    from .. import api

    t0, c0 = time.perf_counter(), time.process_time()
    out: dict[str, Any] = {"status": "failed", "error": "", "stories": None, "walls": None, "rooms": None,
                           "area_m2": None, "faces": None, "warnings": []}
    with _captured() as (caught, logs):
        try:
            result = api.run(scan, annotations=annotations, output=output, force=force, options=options)
            from ..export.planjson import plan_document

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
