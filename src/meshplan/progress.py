"""Terminal progress and the end-of-run summaries (rich, on stderr): a spinner per stage of a run
(:class:`StageProgress`) and its summary (:func:`print_summary`); a bar over the scans of a
batch (:class:`BatchProgress`) and its summary (:func:`print_batch_summary`)."""

from __future__ import annotations

import contextlib
import logging
import sys
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # pragma: no cover
    from .batch.summary import BatchSummary, ScanRow
    from .result import Result

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
    """A spinner per pipeline stage; does nothing when disabled or not on a terminal.

    A stage may run in several parts (``slice_draw``: the slices computed with the other stages,
    then the plans drawn while the files are made): its line spins again while each part runs,
    and its time is the sum of the parts.
    """

    def __init__(self, enabled: bool = True) -> None:
        self.enabled = enabled and sys.stderr.isatty()
        self._progress: Any = None
        self._tasks: dict[str, Any] = {}
        self._stack = contextlib.ExitStack()

    def __enter__(self) -> StageProgress:
        return self

    def __exit__(self, *exc: Any) -> None:
        self._stack.__exit__(*exc)

    def _start(self) -> None:
        """Show the display, at the run's first stage. Not before: the live display redraws
        itself from a thread of its own, and the run forks its drawing workers as it starts
        (:class:`meshplan.export.RenderPool`); a worker forked while that thread held the
        console's or stderr's lock would wait for it for ever the first time it printed."""
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn

        self._progress = Progress(
            SpinnerColumn(), TextColumn("{task.description}"), _StageTimeColumn(), console=Console(stderr=True), transient=False
        )
        self._stack.enter_context(self._progress)
        self._stack.enter_context(logs_above_live_display())

    def update(self, stage: str, event: str) -> None:
        if not self.enabled:
            return
        if self._progress is None:
            self._start()
        task = self._tasks.get(stage)
        if task is None:
            self._tasks[stage] = self._progress.add_task(STAGE_NAMES.get(stage, stage), total=1, before_s=0.0)
        elif event == "start":  # a stage's next part: running again, its time so far kept
            done = self._progress.tasks[self._task_index(task)]
            self._progress.reset(task, total=1, completed=0, before_s=_stage_seconds(done))
        if event == "done":
            self._progress.update(self._tasks[stage], completed=1)

    def _task_index(self, task_id: Any) -> int:
        return next(i for i, t in enumerate(self._progress.tasks) if t.id == task_id)


def _stage_seconds(task: Any) -> float:
    """Seconds a stage's line has run: its earlier parts and the current one."""
    elapsed = task.finished_time if task.finished else task.elapsed
    return float(task.fields.get("before_s", 0.0)) + float(elapsed or 0.0)


def _StageTimeColumn() -> Any:
    """rich's elapsed-time column, counting every part of a stage."""
    from datetime import timedelta

    from rich.progress import ProgressColumn
    from rich.text import Text

    class StageTimeColumn(ProgressColumn):
        def render(self, task: Any) -> Text:
            return Text(str(timedelta(seconds=int(_stage_seconds(task)))), style="progress.elapsed")

    return StageTimeColumn()


def print_summary(result: Result) -> None:
    """Stories, walls, rooms, timings against the paper's, and where the files are."""
    from rich.console import Console
    from rich.table import Table

    from .result import PAPER_TIMINGS_S

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
