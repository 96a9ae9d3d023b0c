"""Writing files and directories so that a reader never sees half of them.

Single files go to a temporary name in the same directory and are renamed into place
(``os.replace`` is atomic on POSIX and Windows). A result directory is built completely under a
hidden temporary name beside its destination and renamed into place only when every file is in
it; an existing result is replaced only on request. A run killed at any moment therefore leaves
either the complete previous result or none, never a mixture; hidden leftovers of a killed run are
removed by the next run that writes to the same place.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

from ..errors import OutputError

_TMP_TAG = ".meshplan-tmp-"
_OLD_TAG = ".meshplan-old-"


def atomic_write_bytes(path: str | os.PathLike, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file and a rename."""
    p = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}{_TMP_TAG}", dir=p.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise


def atomic_write_text(path: str | os.PathLike, text: str) -> None:
    atomic_write_bytes(path, text.encode("utf-8"))


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def remove_stale(target: Path) -> None:
    """Delete hidden leftovers of killed runs that wrote to ``target``; restore a lost result."""
    parent = target.parent
    if not parent.is_dir():
        return
    for entry in parent.iterdir():
        name = entry.name
        for tag in (_TMP_TAG, _OLD_TAG):
            prefix = f".{target.name}{tag}"
            if not name.startswith(prefix):
                continue
            try:
                pid = int(name[len(prefix):].split("-")[0])
            except ValueError:
                continue
            if _pid_alive(pid) and pid != os.getpid():
                continue
            if tag == _OLD_TAG and not target.exists():
                # killed between moving the old result aside and moving the new one in
                with contextlib.suppress(OSError):
                    os.replace(entry, target)
                continue
            shutil.rmtree(entry, ignore_errors=True) if entry.is_dir() else entry.unlink(missing_ok=True)


def check_output_dir(target: str | os.PathLike, force: bool) -> Path:
    """Check, before any work, that a result directory can be created at ``target``."""
    t = Path(target)
    if t.exists() and not t.is_dir():
        raise OutputError(f"{t}: exists and is not a directory", "choose another output path with -o")
    if t.exists() and not force:
        raise OutputError(f"{t}: output directory already exists", "pass --force to replace it, or choose another with -o")
    parent = t.parent if str(t.parent) else Path(".")
    probe = parent
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir() or not os.access(probe, os.W_OK | os.X_OK):
        raise OutputError(f"{t}: cannot write in {probe}", "choose a writable output directory with -o")
    return t


@contextlib.contextmanager
def staged_directory(target: str | os.PathLike, force: bool = False) -> Iterator[Path]:
    """Yield an empty hidden directory; on success it replaces ``target`` in one rename.

    On any exception the staged directory is deleted and ``target`` is left as it was.
    """
    t = check_output_dir(target, force)
    try:
        t.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputError(f"{t.parent}: cannot be created ({exc.strerror})", "choose a writable output directory with -o") from None
    remove_stale(t)
    try:
        tmp = Path(tempfile.mkdtemp(prefix=f".{t.name}{_TMP_TAG}{os.getpid()}-", dir=t.parent))
    except OSError as exc:
        raise OutputError(f"{t.parent}: cannot be written ({exc.strerror})", "choose a writable output directory with -o") from None
    try:
        yield tmp
        os.chmod(tmp, 0o755)
        if t.exists():
            if not force:
                raise OutputError(f"{t}: output directory already exists", "pass --force to replace it")
            old = Path(tempfile.mkdtemp(prefix=f".{t.name}{_OLD_TAG}{os.getpid()}-", dir=t.parent))
            os.replace(t, old)
            os.replace(tmp, t)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, t)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
