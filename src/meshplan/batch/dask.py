"""Scans on a Dask distributed cluster (the ``meshplan[dask]`` extra, imported lazily; see
:mod:`meshplan.batch`, "Dask")."""

from __future__ import annotations

import contextlib
import uuid
from collections.abc import Callable, Sequence
from typing import Any

from ..errors import MeshplanError
from .worker import _one_line

__all__: list[str] = []


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
