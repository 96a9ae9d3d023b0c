"""The command's allocator settings (meshplan._memory): freed arrays are kept for reuse."""

from __future__ import annotations

import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc's malloc on Linux only")

#: Resident memory (bytes) a 20 MiB array leaves behind once freed, printed by a fresh interpreter.
_CHILD = """
import os, sys
import numpy as np
from meshplan._memory import keep_freed_memory
if sys.argv[1] == "keep":
    assert keep_freed_memory()
def rss():
    return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
a = np.ones(20 * 2**20 // 8)
before = rss()
del a
print(before - rss())
"""


def _released_bytes(mode: str, env: dict[str, str] | None = None) -> int:
    out = subprocess.run([sys.executable, "-c", _CHILD, mode], capture_output=True, text=True, check=True, env=env)
    return int(out.stdout.strip())


def _glibc() -> bool:
    import ctypes

    return hasattr(ctypes.CDLL(None), "gnu_get_libc_version")


@pytest.mark.skipif(not _glibc(), reason="glibc only")
def test_a_freed_array_is_kept_for_the_next_one() -> None:
    # by default glibc maps a 20 MiB block on its own and returns it to the kernel when freed;
    # once kept, the next arrays reuse those pages instead of faulting new ones in
    assert _released_bytes("default") >= 16 * 2**20
    assert _released_bytes("keep") <= 2 * 2**20


@pytest.mark.skipif(not _glibc(), reason="glibc only")
def test_the_users_own_allocator_settings_are_left_alone(monkeypatch: pytest.MonkeyPatch) -> None:
    from meshplan._memory import keep_freed_memory

    monkeypatch.setenv("MALLOC_MMAP_THRESHOLD_", "131072")
    assert keep_freed_memory() is False


@pytest.mark.skipif(not _glibc(), reason="glibc only")
def test_the_command_keeps_freed_memory() -> None:
    # loaded as the ``meshplan`` program, the command line sets the allocator up itself (also
    # when started with Ctrl-C ignored, as a shell's background job is: pytest may run so)
    child = _CHILD.replace("from meshplan._memory import keep_freed_memory", "sys.argv[0] = 'meshplan'; import meshplan.cli")
    out = subprocess.run([sys.executable, "-c", child, "command"], capture_output=True, text=True, check=True)
    assert int(out.stdout.strip()) <= 2 * 2**20


#: Resident memory (bytes) a 20 MiB array made after another thread freed one adds.
_THREAD_CHILD = """
import os, sys, threading
import numpy as np
from meshplan._memory import keep_freed_memory
assert keep_freed_memory()
def rss():
    return int(open("/proc/self/statm").read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
def work():
    a = np.ones(20 * 2**20 // 8)
    del a
t = threading.Thread(target=work)
t.start()
t.join()
before = rss()
b = np.ones(20 * 2**20 // 8)
print(rss() - before)
"""


@pytest.mark.skipif(not _glibc(), reason="glibc only")
def test_what_a_thread_frees_the_run_reuses() -> None:
    # one heap for every thread: the stages' threads' freed arrays serve the next ones (with a
    # heap per thread, the 3M-face run's peak rose by up to 0.27 GB); a user's own setting is
    # left alone, and then the thread's heap keeps its block
    import os

    env = {k: v for k, v in os.environ.items() if k != "MALLOC_ARENA_MAX"}
    out = subprocess.run([sys.executable, "-c", _THREAD_CHILD], capture_output=True, text=True, check=True, env=env)
    assert int(out.stdout.strip()) <= 2 * 2**20
    out = subprocess.run([sys.executable, "-c", _THREAD_CHILD], capture_output=True, text=True, check=True, env={**env, "MALLOC_ARENA_MAX": "8"})
    assert int(out.stdout.strip()) >= 16 * 2**20


_PAGES_CHILD = """
import sys
sys.argv[0] = "meshplan"
import meshplan.cli  # loaded as the program, before numpy
import numpy._core.multiarray as m
print(m._set_madvise_hugepage(False))  # the previous setting: whether numpy asks for huge pages
"""


def test_the_command_keeps_numpy_from_asking_for_huge_pages() -> None:
    # each huge page faulted in is a 2 MiB round trip to the host in a virtual machine that hands
    # free memory back (meshplan._memory): the command keeps numpy's arrays in small pages
    import os

    env = {k: v for k, v in os.environ.items() if k != "NUMPY_MADVISE_HUGEPAGE"}
    out = subprocess.run([sys.executable, "-c", _PAGES_CHILD], capture_output=True, text=True, check=True, env=env)
    assert out.stdout.strip() == "False"
    # the user's own setting is left alone
    out = subprocess.run([sys.executable, "-c", _PAGES_CHILD], capture_output=True, text=True, check=True, env={**env, "NUMPY_MADVISE_HUGEPAGE": "1"})
    assert out.stdout.strip() == "True"


def test_the_collector_paused_and_resumed_once() -> None:
    import gc

    from meshplan import _memory

    assert gc.isenabled()
    try:
        assert _memory.pause_collector()
        assert not gc.isenabled()
        assert not _memory.pause_collector()  # already paused: nothing to do
        frozen = gc.get_freeze_count()
        assert _memory.resume_collector()
        assert gc.isenabled() and gc.get_freeze_count() > frozen  # what was loaded set aside
        assert not _memory.resume_collector()  # once
        # a collector the user turned off stays off
        gc.disable()
        assert not _memory.pause_collector()
        assert not _memory.resume_collector() and not gc.isenabled()
    finally:
        gc.enable()
        gc.unfreeze()


_COLLECTOR_CHILD = """
import gc, sys
sys.argv[0] = "meshplan"
import meshplan.cli as cli  # loaded as the program
print(gc.isenabled())
import meshplan.api as api
def run(*args, **kwargs):  # where the run would start: what is loaded, and the collector
    print(gc.isenabled(), gc.get_freeze_count() > 50_000, "numba.np.arraymath" in sys.modules)
    raise SystemExit(0)
api.run = run
cli.main(sys.argv[1:])
print(gc.isenabled())
"""


def test_the_program_loads_its_libraries_with_the_collector_paused(tmp_path) -> None:
    # the program loads typer, numpy, scipy and numba's machinery (its first stage's) with the
    # collector off, then freezes them and turns it back on before the run starts
    scan = tmp_path / "scan.ply"
    scan.write_text("ply\n")
    argv = ["run", str(scan), "-o", str(tmp_path / "out"), "--quiet"]
    out = subprocess.run([sys.executable, "-c", _COLLECTOR_CHILD, *argv], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["False", "True", "True", "True"]
    # another command: the collector is back on when it starts
    out = subprocess.run([sys.executable, "-c", _COLLECTOR_CHILD, "schema"], capture_output=True, text=True, check=True)
    lines = out.stdout.splitlines()
    assert lines[0] == "False" and lines[-1] == "True"
