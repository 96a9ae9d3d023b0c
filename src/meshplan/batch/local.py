"""The crash-tolerant local pool: worker processes taking one scan at a time, a dead worker's scan
reported failed and a new worker taking over the rest (see :mod:`meshplan.batch`, "Local
parallelism")."""

from __future__ import annotations

import contextlib
import logging
import multiprocessing
import os
import signal
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from .._memory import keep_freed_memory
from .worker import _limit_threads, _single_threaded_env

__all__ = ["START_METHOD"]

#: How local worker processes are started (``MESHPLAN_START_METHOD`` overrides it). Measured with
#: ``benchmarks/bench_batch.py`` on a 2-core machine (20 room scans, 2 workers): spawn, fork and
#: forkserver differ by less than the run-to-run noise (well under a second of a ~30 s batch)
#: because each worker imports the pipeline once and then handles many scans, so start-up is
#: paid once per worker. ``spawn`` is chosen as it is safe whatever the parent holds (``fork``
#: copies the parent's threads and locks, e.g. the progress bar's refresh thread and BLAS pools)
#: and each worker starts with the thread limits below in its environment before numpy loads.
START_METHOD = "spawn"


def _worker_main(conn: Any, func: Callable[..., dict[str, Any]]) -> None:
    """A local worker: run ``func(*args)`` for each ``(index, args)`` received, until ``None``.

    The worker starts with SIGINT blocked (see :func:`_run_local`): a Ctrl-C while it was
    starting, or any later, ends it here, quietly (the parent says it in one line).
    """
    try:
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})
        _limit_threads()
        keep_freed_memory()  # a process of meshplan's own, running scan after scan (see _memory)
        logging.getLogger().setLevel(logging.WARNING)
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
        # SIGINT blocked while the worker starts (inherited through fork and exec): a Ctrl-C
        # then reaches it only once it can end quietly, not with a traceback from the middle
        # of its imports
        blocked = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            with _single_threaded_env():
                # not daemonic: a scan may draw with processes > 1 (forked children); stopped in finally
                # typeshed's get_context(str) gives BaseContext, which lacks Process; every concrete context has it
                p = ctx.Process(target=_worker_main, args=(child, func), name="meshplan-batch-worker", daemon=False)  # type: ignore[attr-defined]
                p.start()
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, blocked)
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
