"""Terminal progress and the end-of-run summary (rich, on stderr)."""

from __future__ import annotations

import contextlib
import logging
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .pipeline import Result

STAGE_NAMES = {
    "load": "Reading the scan",
    "orient": "Levelling, floors and ceilings, wall alignment, stories",
    "walls": "Flat walls (box DBSCAN)",
    "rooms": "Rooms and openings",
    "slice_draw": "Slicing and drawing the plans",
    "write": "Writing models and files",
}


@contextlib.contextmanager
def logs_above_live_display() -> Iterator[None]:
    """While a rich live display redirects ``sys.stderr``, send the logging handlers that write
    to the real stderr through that redirection too, so that their lines (``-v``) print above
    the display instead of tearing it apart. Does nothing when stderr is not redirected."""
    from rich.file_proxy import FileProxy

    proxy: Any = sys.stderr
    if not isinstance(proxy, FileProxy):
        yield
        return
    real = proxy.rich_proxied_file
    moved = [h for h in logging.getLogger().handlers if isinstance(h, logging.StreamHandler) and h.stream is real]
    for h in moved:
        h.setStream(proxy)
    try:
        yield
    finally:
        for h in moved:
            h.setStream(real)  # flushes what the proxy still holds, while the display is live


class StageProgress:
    """A spinner per pipeline stage; does nothing when disabled or not on a terminal."""

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._progress: Any = None
        self._tasks: dict[str, int] = {}
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> StageProgress:
        if self.enabled:
            from rich.console import Console
            from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

            self._progress = Progress(
                SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn(), console=Console(stderr=True), transient=False
            )
            self._stack.enter_context(self._progress)
            self._stack.enter_context(logs_above_live_display())
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stack.__exit__(*exc)

    def update(self, stage: str, event: str) -> None:
        if self._progress is None:
            return
        if stage not in self._tasks:
            self._tasks[stage] = self._progress.add_task(STAGE_NAMES.get(stage, stage), total=1)
        if event == "done":
            self._progress.update(self._tasks[stage], completed=1)


def print_summary(result: Result) -> None:
    """Stories, walls, rooms, timings against the paper's, and where the files are."""
    from rich.console import Console
    from rich.table import Table

    from .pipeline import PAPER_TIMINGS_S

    console = Console(stderr=True)
    st = result.input
    console.print(f"[bold]{st.path}[/]: {st.faces:,} faces" + (f" ({st.dropped_faces:,} dropped)" if st.dropped_faces else ""))
    table = Table(title="Stories", show_edge=False)
    for col in ("story", "floor (m)", "ceiling (m)", "height (m)", "walls", "rooms", "doors", "windows", "annotations"):
        table.add_column(col, justify="right")
    for sp in result.stories:
        s = sp.story
        table.add_row(
            str(s.index),
            f"{s.floor:.3f}",
            f"{s.ceiling:.3f}" + ("" if s.ceiling_found else " (assumed)"),
            f"{s.height:.3f}",
            str(int((result.walls.story == s.index).sum())),
            str(sum(r.story == s.index for r in result.rooms)),
            str(sum(k == "door" and st == s.index for k, st in zip(result.openings.kind, result.openings.story))),
            str(sum(k == "window" and st == s.index for k, st in zip(result.openings.kind, result.openings.story))),
            str(len(sp.annotations)),
        )
    console.print(table)
    t = Table(title="Timings (s)", show_edge=False)
    t.add_column("stage")
    t.add_column("meshplan", justify="right")
    t.add_column("paper (B2, 286k faces)", justify="right")
    for name, value in result.timings.items():
        paper = PAPER_TIMINGS_S.get(name)
        t.add_row(name, f"{value:.3f}", f"{paper:.2f}" if paper else "")
    console.print(t)
    for w in result.warnings:
        console.print(f"[yellow]warning:[/] {w}")
    if result.output_dir:
        console.print(f"{len(result.files)} files in [bold]{result.output_dir}[/]")
