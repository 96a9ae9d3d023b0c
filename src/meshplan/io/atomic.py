"""Writing files and directories so that a reader never sees half of them.

Single files go to a temporary name in the same directory and are renamed into place
(``os.replace`` is atomic on POSIX and Windows). A result directory is built completely under a
hidden temporary name beside its destination and renamed into place only when every file is in
it; an existing result is replaced only on request, by swapping the two directories in one step
(Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere two renames, undone by the next run if it is
killed between them). A run killed at any moment therefore leaves either the complete previous
result or none, never a mixture; hidden leftovers of a killed run are removed by the next run
that writes to the same place.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
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
    probe = t.parent if str(t.parent) else Path(".")
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{t}: cannot write there: {probe} is a file, not a directory", "choose another output path with -o")
    # really create something: permission bits say nothing for root, read-only mounts or /proc
    try:
        os.rmdir(tempfile.mkdtemp(prefix=".meshplan-probe-", dir=probe))
    except OSError as exc:
        raise OutputError(
            f"{t}: cannot write in {probe} ({exc.strerror or exc})", "choose a writable output directory with -o"
        ) from None
    return t


_RENAME_EXCHANGE = 2
_AT_FDCWD = -100


def _exchange(a: Path, b: Path) -> bool:
    """Swap two existing paths in one atomic step; ``False`` where the system cannot.

    Uses Linux's ``renameat2(RENAME_EXCHANGE)`` (glibc 2.28 or later; most local filesystems).
    """
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (AttributeError, OSError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p, ctypes.c_uint]
    if renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b), _RENAME_EXCHANGE) == 0:
        return True
    code = ctypes.get_errno()
    if code in (errno.EINVAL, errno.ENOSYS, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV):
        return False
    raise OSError(code, os.strerror(code), str(b))


def _publish(tmp: Path, target: Path, force: bool) -> None:
    """Move the complete staged directory ``tmp`` to ``target``, replacing it when ``force``."""
    if not target.exists():
        os.replace(tmp, target)
        return
    if not force:
        raise OutputError(f"{target}: output directory already exists", "pass --force to replace it")
    if _exchange(tmp, target):
        shutil.rmtree(tmp, ignore_errors=True)  # now the previous result
        return
    # two renames: a run killed between them leaves the previous result under the hidden
    # name, and remove_stale() puts it back
    old = Path(tempfile.mkdtemp(prefix=f".{target.name}{_OLD_TAG}{os.getpid()}-", dir=target.parent))
    os.replace(target, old)
    os.replace(tmp, target)
    shutil.rmtree(old, ignore_errors=True)


def _make_parents(directory: Path, created: list[Path]) -> None:
    """Create ``directory`` and its missing parents, inserting each created one at the front
    of ``created`` (so that it lists them deepest first, even when a mkdir fails)."""
    missing = []
    while not directory.exists() and directory != directory.parent:
        missing.append(directory)
        directory = directory.parent
    for d in reversed(missing):
        d.mkdir()
        created.insert(0, d)


def _remove_created(created: list[Path]) -> None:
    """Remove the directories :func:`_make_parents` created, if they are still empty."""
    for d in created:
        try:
            d.rmdir()
        except OSError:
            break


@contextlib.contextmanager
def staged_directory(target: str | os.PathLike, force: bool = False) -> Iterator[Path]:
    """Yield an empty hidden directory; on success it replaces ``target`` in one rename.

    On any exception the staged directory is deleted and ``target`` is left as it was.
    """
    t = check_output_dir(target, force)
    created: list[Path] = []
    try:
        _make_parents(t.parent, created)
        remove_stale(t)
        tmp = Path(tempfile.mkdtemp(prefix=f".{t.name}{_TMP_TAG}{os.getpid()}-", dir=t.parent))
    except OSError as exc:
        _remove_created(created)
        raise OutputError(f"{t.parent}: cannot be written ({exc.strerror or exc})", "choose a writable output directory with -o") from None
    try:
        try:
            yield tmp
            os.chmod(tmp, 0o755)
            _publish(tmp, t, force)
        except OSError as exc:  # a full disk, a quota, a directory removed under our feet
            what = f" {Path(exc.filename).name}" if exc.filename else ""
            raise OutputError(
                f"{t}: writing{what} failed ({exc.strerror or exc}) and nothing was changed",
                "free some space or choose another output directory with -o",
            ) from None
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        _remove_created(created)
        raise
