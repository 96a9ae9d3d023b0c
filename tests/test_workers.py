"""The drawing workers (:class:`meshplan.export.RenderPool`) die with the run that forked them,
however it dies, and Ctrl-C ends a run with one line and no traceback.

Each of those tests starts a real ``python -m meshplan run`` on a synthetic apartment (about
200,000 faces, several seconds to run on a busy machine), waits for its drawing workers, signals
the run and looks at the workers through ``/proc``. The last one checks that the workers make
the same files as the run alone.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytestmark = [
    pytest.mark.slow,  # whole runs of meshplan: not part of the unit layer (-m "not slow")
    pytest.mark.skipif(not sys.platform.startswith("linux"), reason="drawing workers are forked on Linux only"),
]

#: How long (s) a killed run's workers may take to die: the kernel signals them at once
#: (prctl); the brief allows 2 s.
DEATH_GRACE_S = 2.0
#: How long (s) to wait for a run to fork its workers (it does so before reading the scan).
FORK_TIMEOUT_S = 30.0
#: Workers are looked at this long (s) after they appear, so that they are set up and the run is
#: under way (reading, orienting; the drawings start a few seconds later).
SETTLE_S = 1.5


@pytest.fixture(scope="module")
def apartment(tmp_path_factory) -> Path:
    from meshplan.export.synth import write_synthetic
    from meshplan.synthetic import SynthParams, generate

    out = tmp_path_factory.mktemp("apartment")
    return write_synthetic(generate(SynthParams(preset="apartment", seed=1)), out / "scan", "obj")


def _children(pid: int) -> set[int]:
    """Child processes of ``pid``, from ``/proc/<pid>/task/*/children`` (or every process's
    parent id where the kernel lacks that file)."""
    found: set[int] = set()
    tasks = Path(f"/proc/{pid}/task")
    files = list(tasks.glob("*/children")) if tasks.is_dir() else []
    if files:
        for f in files:
            try:
                found.update(int(p) for p in f.read_text().split())
            except OSError:  # the task ended meanwhile
                pass
        return found
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            fields = stat.read_text().rsplit(")", 1)[1].split()
        except OSError:
            continue
        if int(fields[1]) == pid:
            found.add(int(stat.parent.name))
    return found


def _alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie has died: only its exit status is left)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state not in ("Z", "X")


def _start(scan: Path, out: Path) -> subprocess.Popen:
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    return subprocess.Popen(
        [sys.executable, "-m", "meshplan", "run", str(scan), "-o", str(out), "--quiet"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env=env,
        start_new_session=True,  # its own process group: a Ctrl-C reaches it and its workers only
    )


def _workers(proc: subprocess.Popen) -> set[int]:
    """The run's drawing workers, once they are forked and set up."""
    deadline = time.monotonic() + FORK_TIMEOUT_S
    while time.monotonic() < deadline and proc.poll() is None:
        kids = _children(proc.pid)
        if kids:
            time.sleep(SETTLE_S)
            kids |= _children(proc.pid)
            assert proc.poll() is None, "the run ended before it could be signalled"
            return kids
        time.sleep(0.05)
    pytest.fail(f"no drawing worker appeared within {FORK_TIMEOUT_S:.0f} s (run status {proc.poll()})")


def _cleanup(proc: subprocess.Popen, pids: set[int]) -> None:
    """Kill what the test started, whatever happened: the run, and its workers by their ids."""
    for pid in [proc.pid, *pids]:
        if _alive(pid):
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    try:
        proc.communicate(timeout=10)
    except subprocess.TimeoutExpired:  # pragma: no cover
        pass


@pytest.mark.parametrize("sig", [signal.SIGKILL, signal.SIGTERM], ids=["SIGKILL", "SIGTERM"])
def test_workers_die_with_the_run(apartment, tmp_path, sig):
    proc = _start(apartment, tmp_path / "out")
    pids: set[int] = set()
    try:
        pids = _workers(proc)
        assert all(_alive(p) for p in pids)
        os.kill(proc.pid, sig)
        proc.wait(timeout=10)
        deadline = time.monotonic() + DEATH_GRACE_S
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.05)
        alive = sorted(p for p in pids if _alive(p))
        assert not alive, f"workers {alive} outlived the run killed by {sig.name}"
        assert not (tmp_path / "out").exists()
    finally:
        _cleanup(proc, pids)


def _interrupt(scan: Path, out: Path) -> tuple[int, str, list[int]]:
    """Start a run, Ctrl-C it once its workers are up: (exit status, stderr, the workers still
    alive 2 s after the run ended)."""
    proc = _start(scan, out)
    pids: set[int] = set()
    try:
        pids = _workers(proc)
        os.killpg(proc.pid, signal.SIGINT)  # what a terminal's Ctrl-C does: the whole group
        _, err = proc.communicate(timeout=60)
        deadline = time.monotonic() + DEATH_GRACE_S
        while time.monotonic() < deadline and any(_alive(p) for p in pids):
            time.sleep(0.05)
        return proc.returncode, err.decode("utf-8", "replace"), [p for p in pids if _alive(p)]
    finally:
        _cleanup(proc, pids)


def test_ctrl_c_is_one_line(apartment, tmp_path):
    # On a loaded machine a run signalled this way exited 0 with its files written (twice in a
    # row in one full make test, once in CI before), or crashed with SIGSEGV and nothing on
    # stderr: the KeyboardInterrupt landed in a library's import (swallowed, or a compiled
    # module's initialization left half done). The run now exits at once until it writes
    # (meshplan._ctrl_c; test below): 14 of 14 right under load, against 6 of 8 before (a crash,
    # an internal error). The second try stays: a Ctrl-C that is ignored fails both.
    for attempt in range(2):
        out = tmp_path / f"out{attempt}"
        code, text, survivors = _interrupt(apartment, out)
        if code != 0:
            break
    lines = [line for line in text.splitlines() if line.strip()]
    assert code != 0, text
    assert "Traceback" not in text, text
    # (the status too: a run that crashed ended with a non-zero status and nothing on stderr)
    assert len(lines) == 1 and lines[0].startswith("error: "), (code, text)
    assert not survivors, f"workers {survivors} outlived the interrupted run"
    assert not out.exists()


def test_workers_make_the_same_files_as_the_run_alone(apartment):
    """The drawings, GLB models, DXF files and the report come out the same, byte for byte,
    whether the workers make them (arguments pickled, the scan sent as its vertices and faces)
    or the run itself does."""
    import meshplan
    from meshplan.export import RenderPool, render_files

    result = meshplan.run(apartment)
    with RenderPool(1) as alone:
        assert alone.executor is None
        here = render_files(result, pool=alone)
    with RenderPool(2) as pool:
        there = render_files(result, pool=pool)
    assert sorted(here) == sorted(there)
    assert {"oriented.glb", "story-0.glb", "flat-walls-0.glb", "drafting-0.dxf", "pen-and-ink-0.svg", "report.html"} <= set(here)
    for name in here:
        assert here[name] == there[name], name


def test_a_run_with_workers_writes_what_a_run_alone_writes(apartment, tmp_path):
    """``meshplan.run`` hands the drawings the orientation alone decides (the pen-and-ink plans,
    the normals, the levels) to its workers before the walls and rooms exist, and makes the
    models and DXF files itself meanwhile: every file is the same, byte for byte, as a run
    that draws everything in one process (the report and plan.json aside: they show timings)."""
    import meshplan
    import meshplan.api  # the module patched below (meshplan.run imports it only when called)
    from meshplan import export

    submitted: list = []
    real = export.submit_early

    def spy(pool, oriented, upright=None):
        early = real(pool, oriented, upright)
        submitted.append(early)
        return early

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(meshplan.api, "submit_early", spy)
        meshplan.run(apartment, output=tmp_path / "workers", processes=2)
    meshplan.run(apartment, output=tmp_path / "alone", processes=1)
    # the early drawings did go to the workers, and were all the pen-and-ink plans
    assert len(submitted) == 1 and submitted[0] is not None
    assert all(f is not None for f in submitted[0].futures)
    early_names = {n for job, f in zip(submitted[0].jobs, submitted[0].futures) for n in f.result()}
    assert {"pen-and-ink-0.png", "pen-and-ink-0.svg", "pen-and-ink-0.pdf", "normals.png", "levels.png"} <= early_names
    # the normals and levels went as soon as the scan was oriented, before the pen-and-ink
    # slices were cut (submit_upright): first among the early drawings
    assert [job[0].__name__ for job in submitted[0].jobs[:2]] == ["_normals_files", "_levels_files"]
    names = sorted(p.name for p in (tmp_path / "alone").iterdir())
    assert names == sorted(p.name for p in (tmp_path / "workers").iterdir())
    for name in names:
        if name not in ("report.html", "plan.json"):
            assert (tmp_path / "alone" / name).read_bytes() == (tmp_path / "workers" / name).read_bytes(), name


def _priority() -> int:
    return os.getpriority(os.PRIO_PROCESS, 0)


def test_workers_draw_at_the_runs_priority_where_allowed():
    """A worker warms up at low priority, then draws at the run's (issue 15: left niced, on a
    busy machine the drawings got a fraction of the CPU); without the right to raise a priority
    back, it stays low, as before."""
    import resource

    from meshplan.export import _WARM_UP_NICE, RenderPool

    mine = _priority()
    may_raise = os.geteuid() == 0 or 20 - resource.getrlimit(resource.RLIMIT_NICE)[0] <= mine
    # more processes than cores: the workers warm up niced (with a core each, they would not)
    with RenderPool((os.cpu_count() or 1) + 1) as pool:
        assert pool.executor is not None
        got = {pool.executor.submit(_priority).result(timeout=60) for _ in range(4)}
    assert got == ({mine} if may_raise else {min(mine + _WARM_UP_NICE, 19)})


def _spin(seconds: float) -> dict[str, bytes]:
    """A drawing job that works (uses CPU) for ``seconds``."""
    end = time.process_time() + seconds
    while time.process_time() < end:
        pass
    return {"spun": b"%d" % os.getpid()}


@pytest.mark.timeout(180)  # waiting for ever is what is tested: fail soon, not at the suite's limit
def test_a_stuck_worker_is_killed_and_its_drawings_made_here(apartment, monkeypatch):
    """A worker that uses no CPU while the run waits for its drawings never answers (stopped
    here; in a library caller's process, one forked while another thread held a lock it needs
    waits forever, and the run with it): after ``WORKER_STALL_S`` the run kills its workers and
    draws here, the same files byte for byte."""
    import meshplan
    from meshplan import export
    from meshplan.export import RenderPool, render_files

    result = meshplan.run(apartment)
    with RenderPool(1) as alone:
        here = render_files(result, pool=alone)
    monkeypatch.setattr(export, "WORKER_STALL_S", 1.0)
    with RenderPool(2) as pool:
        pids = list(pool.executor._processes)
        for pid in pids:
            os.kill(pid, signal.SIGSTOP)
        there = render_files(result, pool=pool)
        assert pool.stuck
        assert not any(_alive(p) for p in pids), "the stuck workers were not killed"
    assert sorted(here) == sorted(there)
    for name in here:
        if name != "report.html":  # shows the run's timings
            assert here[name] == there[name], name


def test_a_worker_at_work_is_waited_for_however_long(monkeypatch):
    """Only a worker that uses no CPU is taken for stuck: one drawing for longer than
    ``WORKER_STALL_S`` is waited for, and its files come from it."""
    from meshplan import export
    from meshplan.export import RenderPool, _result, _submit

    monkeypatch.setattr(export, "WORKER_STALL_S", 0.5)
    with RenderPool(2) as pool:
        (worker,) = pool.executor._processes
        job = (_spin, 2.0)
        (future,) = _submit(pool, [job])
        assert _result(job, future, pool) == {"spun": b"%d" % worker}
        assert not pool.stuck


def test_a_dxf_job_goes_to_whichever_side_is_free_first():
    """A DXF job (:class:`meshplan.export._EitherSide`) goes to the worker when the worker's
    last drawing ends before this process comes to the job, and is made here (once: the
    worker's drawing ending later hands nothing over) when this process comes to it first."""
    from meshplan.export import RenderPool, _EitherSide, _submit

    with RenderPool(2) as pool:
        (worker,) = pool.executor._processes
        (drawn,) = _submit(pool, [(_spin, 0.0)])
        drawn.result(timeout=60)
        to_worker = _EitherSide(pool, (_spin, 0.0), drawn)
        assert to_worker.files() == {"spun": b"%d" % worker}

        (drawing,) = _submit(pool, [(_spin, 1.0)])
        here = _EitherSide(pool, (_spin, 0.0), drawing)
        assert here.files() == {"spun": b"%d" % os.getpid()}
        drawing.result(timeout=60)
        assert here.future is None  # nothing handed to the worker afterwards


_SWALLOWED = """
import signal, sys
sys.argv[0] = "meshplan"
import meshplan.cli  # loaded as the program
from meshplan._ctrl_c import exit_at_once_from_now
exit_at_once_from_now()  # what `meshplan run` does first
try:  # a library's import that catches what was raised inside it
    signal.raise_signal(signal.SIGINT)
except BaseException:
    pass
print("went on")
"""

_WRITING = """
import pathlib, signal, sys
sys.argv[0] = "meshplan"
import meshplan.cli
from meshplan._ctrl_c import exit_at_once_from_now
from meshplan.io import staged_directory
exit_at_once_from_now()
out = pathlib.Path(sys.argv[1])
try:
    with staged_directory(out) as tmp:
        (tmp / "plan.json").write_text("{}")
        signal.raise_signal(signal.SIGINT)
except KeyboardInterrupt:
    print("cleaned up:", sorted(p.name for p in out.parent.iterdir()))
"""


def test_ctrl_c_before_the_run_writes_ends_it_whatever_catches_it(tmp_path):
    """Until the run writes, Ctrl-C ends the program at once with its one line: raised as an
    exception it could be swallowed by a library's guarded import (the run went on and exited 0
    with its files written), turned into an internal error, or crash the process inside a
    compiled module's initialization. Once it writes, Ctrl-C raises again, so that the staged
    directory is removed."""
    out = subprocess.run([sys.executable, "-c", _SWALLOWED], capture_output=True, text=True, timeout=120)
    assert (out.returncode, out.stdout, out.stderr) == (130, "", "error: interrupted; nothing was written\n")
    out = subprocess.run([sys.executable, "-c", _WRITING, str(tmp_path / "out")], capture_output=True, text=True, timeout=120)
    assert (out.returncode, out.stdout.strip(), out.stderr) == (0, "cleaned up: []", "")


def test_the_processs_objects_are_set_aside_from_the_collector_while_workers_share_them(apartment, tmp_path, monkeypatch):
    """While a run's workers share its memory, the objects the run held when it forked them are
    frozen (``gc.freeze``: no collection goes over them, nor writes to the pages the workers
    share); after the run, failed or not, they are collected as before. A run without workers
    freezes nothing, nor does one whose process has objects frozen already (it thaws none)."""
    import gc

    import meshplan
    import meshplan.export as export
    from meshplan.export import RenderPool

    assert gc.get_freeze_count() == 0
    seen: list[int] = []
    meshplan.run(apartment, output=tmp_path / "out", progress=lambda stage, what: seen.append(gc.get_freeze_count()))
    assert seen and min(seen) > 10_000  # numpy's, scipy's, numba's objects, and meshplan's own
    assert gc.get_freeze_count() == 0
    with pytest.raises(RuntimeError), RenderPool(2) as pool:
        assert pool.executor is not None and gc.get_freeze_count() > 10_000
        raise RuntimeError("a stage failed")
    assert gc.get_freeze_count() == 0
    with RenderPool(1):  # no worker to share with
        assert gc.get_freeze_count() == 0
    # objects frozen already (the program's libraries, or a caller's own) stay frozen after a
    # run: the run does not thaw what it did not freeze
    gc.freeze()
    try:
        held = gc.get_freeze_count()  # (frozen objects freed meanwhile leave the count)
        with RenderPool(2) as pool:
            assert pool.executor is not None and gc.get_freeze_count() <= held
        assert gc.get_freeze_count() > held // 2  # not thawed (that leaves none)
    finally:
        gc.unfreeze()
    monkeypatch.setattr(export, "FROZEN_DURING_RUN", False)
    with RenderPool(2) as pool:
        assert pool.executor is not None and gc.get_freeze_count() == 0


_INHERITS = """
import sys
from meshplan.export import RenderPool
from meshplan.render.sheet import Sheet, rasterize_segments
import numpy as np
loaded = "numba.np.arraymath" in sys.modules  # imported by numba's first kernel call
with RenderPool(2) as pool:
    assert pool.executor is not None
    print(loaded, pool.executor.submit(eval, "'numba.np.arraymath' in __import__('sys').modules").result())
    segments = np.array([[[0.0, 0.0], [1.0, 0.5]]])
    got = pool.executor.submit(rasterize_segments, segments, np.zeros(1, int), Sheet(0.0, 2.0, 0.0, 2.0, 10, 10)).result()
    print(int(got.sum()))
"""


def test_the_worker_inherits_numbas_machinery_for_its_rasters():
    """The run loads numba's machinery before it forks its worker (``load_machinery``), so
    that the worker's pen-and-ink rasters (a compiled kernel) do not load it again: in a fresh
    process it is not loaded before the pool starts, and the worker has it before its first
    kernel."""
    out = subprocess.run([sys.executable, "-c", _INHERITS], capture_output=True, text=True, timeout=120, check=True).stdout.split()
    assert out[:2] == ["False", "True"]
    assert int(out[2]) > 0  # the worker's raster counts the segment's pixels


_WARMED = """
import gc, sys
from meshplan.export import RenderPool
assert "matplotlib" not in sys.modules
with RenderPool(2) as pool:
    assert pool.executor is not None
    parent = gc.get_freeze_count()
    job = "(__import__('gc').isenabled(), __import__('gc').get_freeze_count(), 'matplotlib.figure' in __import__('sys').modules)"
    enabled, frozen, loaded = pool.executor.submit(eval, job).result()
    print(enabled, loaded, frozen - parent)
"""


def test_the_worker_loads_matplotlib_with_the_collector_paused_then_sets_it_aside():
    """The worker's warm-up loads matplotlib with the garbage collector paused, then freezes
    what it loaded and turns the collector back on (meshplan._memory.pause_collector): its
    drawings' collections do not walk matplotlib's objects."""
    out = subprocess.run([sys.executable, "-c", _WARMED], capture_output=True, text=True, timeout=120, check=True).stdout.split()
    assert out[:2] == ["True", "True"]
    assert int(out[2]) > 20_000  # matplotlib's objects, frozen beside those the run froze


_HALF_A_RESULT = """
import os, struct, sys, threading, time
from meshplan.export import RenderPool

def half_a_result(fd):
    # a result cut short, as a worker killed while sending one leaves it
    os.write(fd, struct.pack("!i", 1_000_000) + b"x" * 10)
    time.sleep(600)

pool = RenderPool(2)
pool.executor.submit(half_a_result, pool.executor._result_queue._writer.fileno())
time.sleep(1.0)
left = threading.Event()
def leave():
    pool.__exit__(KeyboardInterrupt, KeyboardInterrupt(), None)
    left.set()
threading.Thread(target=leave, daemon=True).start()
print("left" if left.wait(30) else "hung", flush=True)
os._exit(0)
"""


def test_a_worker_killed_while_sending_a_result_does_not_hang_the_run():
    """A run that fails or is interrupted kills its workers; one killed half-way through sending
    a result left half a message in the result pipe, which the executor's manager thread waited
    on for ever, and the run with it (seen once in the suite, as Ctrl-C while writing): the run
    now leaves at once."""
    out = subprocess.run([sys.executable, "-c", _HALF_A_RESULT], capture_output=True, text=True, timeout=120, check=True)
    assert out.stdout.strip() == "left"
