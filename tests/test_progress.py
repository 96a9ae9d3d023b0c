"""What ``meshplan run`` prints: a progress display per stage on a terminal, a short summary
at the end, nothing with ``--quiet``, JSON with ``--json``, debug logging with ``-v``."""

from __future__ import annotations

import json
import logging
import os
import pty
import re
import select
import subprocess
import sys
from pathlib import Path

import pytest

from meshplan.cli import main
from meshplan.export.synth import write_synthetic
from meshplan.pipeline import STAGES
from meshplan.progress import STAGE_NAMES
from meshplan.synthetic import SynthParams, generate

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")


@pytest.fixture(scope="module")
def scan(tmp_path_factory) -> Path:
    """A small synthetic room (about 1 s to run)."""
    d = tmp_path_factory.mktemp("progress")
    return write_synthetic(generate(SynthParams(preset="room", seed=4, triangle_size_m=(0.12, 0.2))), d / "room")


@pytest.fixture
def records(monkeypatch):
    """Log records reaching the "meshplan" logger, whatever the CLI does to the root logger's
    handlers; the root logger is restored afterwards (the CLI configures it for the process)."""
    root = logging.getLogger()
    logger = logging.getLogger("meshplan")
    saved = (root.handlers[:], root.level, logger.level)
    got: list[logging.LogRecord] = []

    class Collect(logging.Handler):
        def emit(self, record: logging.LogRecord) -> None:
            got.append(record)

    handler = Collect(logging.DEBUG)
    logger.addHandler(handler)
    monkeypatch.setenv("COLUMNS", "300")  # no line breaks in long paths in rich's output
    yield got
    logger.removeHandler(handler)
    for h in root.handlers[:]:
        if h not in saved[0]:
            root.removeHandler(h)
    for h in saved[0]:
        if h not in root.handlers:
            root.addHandler(h)
    root.setLevel(saved[1])
    logger.setLevel(saved[2])


def test_quiet_prints_nothing(scan, tmp_path, capsys, records):
    out = tmp_path / "out"
    assert main(["run", str(scan), "-o", str(out), "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""
    assert (out / "plan.json").is_file()


def test_json_summary(scan, tmp_path, capsys, records):
    out = tmp_path / "out"
    assert main(["run", str(scan), "-o", str(out), "--json"]) == 0
    captured = capsys.readouterr()
    summary = json.loads(captured.out)
    assert captured.err == ""  # no progress display when printing JSON
    assert summary["output"] == str(out) and summary["scan"] == str(scan)
    assert len(summary["stories"]) == 1 and {"floor", "ceiling"} <= set(summary["stories"][0])
    assert isinstance(summary["walls"], int) and summary["walls"] >= 4
    assert len(summary["rooms"]) >= 1 and all(r["area"] > 0 for r in summary["rooms"])
    assert set(STAGES) | {"total"} <= set(summary["timings"])
    assert all(v >= 0 for v in summary["timings"].values())
    plan = json.loads((out / "plan.json").read_text())
    assert summary["walls"] == len(plan["walls"]) and len(summary["rooms"]) == len(plan.get("rooms") or [])


def test_summary_says_where_the_files_are_and_no_debug_by_default(scan, tmp_path, capsys, records):
    out = tmp_path / "out"
    assert main(["run", str(scan), "-o", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out == ""  # the summary goes to stderr, like the progress
    err = captured.err
    assert f"files in {out}" in err
    for word in ("Stories", "walls", "rooms", "Timings", "orient", "paper"):
        assert word in err
    assert not [r for r in records if r.levelno < logging.INFO]


def test_verbose_logs_debug_records(scan, tmp_path, capsys, records):
    assert main(["run", str(scan), "-o", str(tmp_path / "out"), "-v", "--json"]) == 0
    debug = [r for r in records if r.levelno == logging.DEBUG and r.name.startswith("meshplan")]
    assert debug, "no debug record from the meshplan logger"
    stages = {r.getMessage().split(":")[0] for r in debug if r.getMessage().startswith("stage ")}
    assert {f"stage {s}" for s in STAGES} <= stages
    captured = capsys.readouterr()
    json.loads(captured.out)  # the log goes to stderr, never into the JSON
    assert "DEBUG meshplan: stage orient" in captured.err
    # -v is meshplan's debug, not every library's (matplotlib alone logs dozens of lines)
    assert not [r for r in records if r.levelno == logging.DEBUG and not r.name.startswith("meshplan")]
    assert "DEBUG matplotlib" not in captured.err


def test_quiet_wins_over_verbose(scan, tmp_path, capsys, records):
    assert main(["run", str(scan), "-o", str(tmp_path / "out"), "-v", "--quiet"]) == 0
    captured = capsys.readouterr()
    assert captured.out == "" and captured.err == ""


def _run_on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, str]:
    """Run ``python -m meshplan ARGV`` with stdout and stderr on a pseudo-terminal: (exit
    status, what it printed without terminal control sequences)."""
    master, slave = pty.openpty()
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "200", "LINES": "50"}
    env.pop("NO_COLOR", None)
    proc = subprocess.Popen([sys.executable, "-m", "meshplan", *argv], stdin=subprocess.DEVNULL, stdout=slave, stderr=slave, cwd=cwd, env=env)
    os.close(slave)
    chunks: list[bytes] = []
    try:
        while True:
            ready, _, _ = select.select([master], [], [], 120)
            if not ready:
                proc.kill()
                raise AssertionError("meshplan run produced no output for 2 minutes")
            try:
                data = os.read(master, 65536)
            except OSError:  # EIO: the terminal's other side is closed, the process is done
                break
            if not data:
                break
            chunks.append(data)
    finally:
        os.close(master)
        code = proc.wait(timeout=60)
    text = b"".join(chunks).decode("utf-8", "replace")
    return code, re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", text)  # without colours and cursor moves


def test_progress_per_stage_on_a_terminal(scan, tmp_path):
    out = tmp_path / "out"
    code, text = _run_on_a_terminal(["run", str(scan), "-o", str(out), "-v"], tmp_path)
    assert code == 0, text
    for stage in STAGES:
        assert STAGE_NAMES[stage] in text, f"no progress line for stage {stage}"
    assert f"files in {out}" in text and "Timings" in text
    # debug lines print on lines of their own, above the display, not glued to a stage's timer
    assert "DEBUG meshplan: stage orient" in text
    assert not re.search(r"\d:\d\d:\d\dDEBUG", text), text
    assert "Traceback" not in text


def test_the_display_starts_after_the_drawing_workers_are_forked(scan, tmp_path, monkeypatch):
    """The live display redraws itself from a thread of its own: a drawing worker forked while
    that thread held the console's or stderr's lock would wait for it for ever the first time it
    printed. The run forks its workers before its first stage, and the display starts there."""
    import threading

    import meshplan
    from meshplan import export
    from meshplan.progress import StageProgress

    threads_at_fork: list[int] = []
    real = export.RenderPool.__init__

    def spy(self, processes):
        threads_at_fork.append(threading.active_count())
        real(self, processes)

    monkeypatch.setattr(export.RenderPool, "__init__", spy)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: True, raising=False)
    alone = threading.active_count()
    with StageProgress() as display:
        assert display.enabled
        assert threading.active_count() == alone  # nothing shown before the run's first stage
        meshplan.run(scan, output=tmp_path / "out", progress=display.update, processes=2)
        assert threading.active_count() > alone  # then the display is live, with its thread
    assert threads_at_fork == [alone]


def test_ctrl_c_on_a_terminal_shows_the_cursor_and_says_so_on_a_line_of_its_own(scan, tmp_path):
    """Ctrl-C ends the run at once while its progress display is live (meshplan._ctrl_c): the
    display hid the cursor and has no chance to show it again, so the program does, and its one
    line starts on a line of its own instead of after the display's last."""
    import signal
    import time

    master, slave = pty.openpty()
    env = {**os.environ, "TERM": "xterm-256color", "COLUMNS": "200", "LINES": "50"}
    argv = [sys.executable, "-m", "meshplan", "run", str(scan), "-o", str(tmp_path / "out")]
    proc = subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=slave, stderr=slave, env=env, start_new_session=True)
    os.close(slave)
    out, sent, deadline = b"", False, time.monotonic() + 120
    try:
        while time.monotonic() < deadline:
            if not sent and STAGE_NAMES["load"].encode() in out:  # the display is live
                os.killpg(proc.pid, signal.SIGINT)
                sent = True
            ready, _, _ = select.select([master], [], [], 0.05)
            if ready:
                try:
                    data = os.read(master, 65536)
                except OSError:  # EIO: the other side is closed
                    break
                if not data:
                    break
                out += data
    finally:
        os.close(master)
        code = proc.wait(timeout=60)
    assert sent and code == 130, (code, out[-300:])
    assert out.count(b"\x1b[?25l") == out.count(b"\x1b[?25h") >= 1, out[-300:]
    assert out.endswith(b"\x1b[?25h\r\nerror: interrupted; nothing was written\r\n"), out[-300:]
    assert not (tmp_path / "out").exists()
