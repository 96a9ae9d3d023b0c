"""The batch's summary: one :class:`ScanRow` per scan, the :class:`BatchSummary` of them all,
written as ``summary.csv`` and ``summary.json``."""

from __future__ import annotations

import csv
import io
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..io import atomic_write_text

__all__ = ["SUMMARY_COLUMNS", "SUMMARY_FILES", "BatchSummary", "ScanRow"]

#: Columns of ``summary.csv`` (``summary.json`` has these and a few more per scan).
SUMMARY_COLUMNS = ("scan", "output", "status", "error", "stories", "walls", "rooms", "area_m2", "faces", "time_s")

#: Names of the summary files written into the batch's output directory.
SUMMARY_FILES = ("summary.csv", "summary.json")


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
