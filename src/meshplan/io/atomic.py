"""Writing files and directories so that a reader never sees half of them.

Single files go to a temporary name in the same directory and are renamed into place
(``os.replace`` is atomic on POSIX and Windows). A result directory is built completely under a
hidden temporary name beside its destination and renamed into place only when every file is in
it; an existing result is replaced only on request, by swapping the two directories in one step
(Linux ``renameat2(RENAME_EXCHANGE)``; elsewhere two renames, undone by the next run if it is
killed between them). A run killed at any moment therefore leaves either the complete previous
result or none, never a mixture; hidden leftovers of a killed run are removed by the next run
that writes to the same place.

meshplan only ever replaces a directory it made: every result directory holds a stamp,
``.meshplan`` (JSON: what kind of directory it is and the files meshplan wrote into it), and
``force`` replaces an existing directory only when it is empty, or when its stamp is of the same
kind and lists every entry in it. The scan, the annotations and the working directory are never
inside what is replaced. Anything else is refused before any work, in one line.
"""

from __future__ import annotations

import contextlib
import ctypes
import errno
import json
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from pathlib import Path

from .._ctrl_c import raise_from_now
from ..errors import OutputError

_TMP_TAG = ".meshplan-tmp-"
_OLD_TAG = ".meshplan-old-"

#: Name of the stamp that marks a directory as meshplan's own (see the module's docstring).
STAMP_NAME = ".meshplan"

#: Kinds of directory meshplan writes; ``force`` replaces only a directory of the same kind.
KIND_PLANS = "plans"
KIND_SYNTHETIC = "synthetic scan"

#: Characters the hidden staging names add to an output name: ``.`` + name + the tag + a pid
#: (up to 7 digits) + ``-`` + mkdtemp's 8 random characters, with a margin.
_STAGING_NAME_EXTRA = len(_TMP_TAG) + 24

#: How many unexpected entries a refusal names (the rest are counted).
_NAMES_SHOWN = 3


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
            if entry.is_dir() and not entry.is_symlink():
                shutil.rmtree(entry, ignore_errors=True)
            else:
                entry.unlink(missing_ok=True)


def _read_stamp(directory: Path) -> dict | None:
    """The stamp of ``directory``, or ``None`` where it has none or an unreadable one."""
    try:
        doc = json.loads((directory / STAMP_NAME).read_text(encoding="utf-8"))
    except (OSError, ValueError, UnicodeDecodeError):
        return None
    if not isinstance(doc, dict) or not isinstance(doc.get("files"), list):
        return None
    return doc


def write_stamp(directory: Path, kind: str) -> None:
    """Mark ``directory`` as meshplan's own, listing the entries it holds now."""
    from .._version import __version__

    files = sorted(e.name for e in directory.iterdir() if e.name != STAMP_NAME)
    doc = {"meshplan": __version__, "kind": kind, "files": files}
    (directory / STAMP_NAME).write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")


def _inside(path: Path, directory: Path) -> bool:
    """Whether ``path`` is ``directory`` or lies somewhere below it (both resolved)."""
    return path == directory or directory in path.parents


def _check_replaceable(t: Path, kind: str, protect: Iterable[str | os.PathLike | None]) -> None:
    """Refuse to replace ``t`` unless meshplan made it (see the module's docstring)."""
    real = t.resolve()
    hint = "choose another output directory with -o"
    try:
        cwd: list[Path] = [Path.cwd()]
    except OSError:  # the working directory was deleted: nothing there to protect
        cwd = []
    for p in [*cwd, *(Path(x) for x in protect if x is not None)]:
        if _inside(Path(os.path.realpath(p)), real):
            what = "the working directory" if cwd and p is cwd[0] else str(p)
            raise OutputError(f"{t}: --force would replace a directory that holds {what}", hint)
    entries = sorted(e.name for e in real.iterdir())
    if not entries:
        return
    stamp = _read_stamp(real)
    if stamp is None:
        raise OutputError(
            f"{t}: --force only replaces a directory that meshplan wrote, and this one has no {STAMP_NAME} stamp",
            f"{hint}, or empty or remove it yourself",
        )
    if stamp.get("kind", KIND_PLANS) != kind:
        raise OutputError(f"{t}: --force would replace a {stamp.get('kind')} directory with {kind}", hint)
    known = {str(f) for f in stamp["files"]} | {STAMP_NAME}
    foreign = [e for e in entries if e not in known]
    if foreign:
        more = f" and {len(foreign) - _NAMES_SHOWN} more" if len(foreign) > _NAMES_SHOWN else ""
        raise OutputError(
            f"{t}: holds files that meshplan did not write ({', '.join(foreign[:_NAMES_SHOWN])}{more}), which --force would delete",
            f"move them out of it or {hint}",
        )


def _name_max(directory: Path) -> int:
    """The longest file name the file system of ``directory`` takes (255 where unknown)."""
    try:
        return os.pathconf(directory, "PC_NAME_MAX")
    except (OSError, ValueError, AttributeError):
        return 255


def check_output_dir(
    target: str | os.PathLike, force: bool, *, kind: str = KIND_PLANS, protect: Iterable[str | os.PathLike | None] = ()
) -> Path:
    """Check, before any work, that a result directory of ``kind`` can be created at ``target``.

    Parameters
    ----------
    target
        The result directory. A symbolic link to a directory is followed (the directory it points
        to is replaced and the link kept); ``.`` and ``..`` mean the directories they name.
    force
        Replace an existing directory, which is allowed only where meshplan made it (its
        ``.meshplan`` stamp is of ``kind`` and lists every entry in it) or where it is empty.
    kind
        What meshplan writes there (:data:`KIND_PLANS`, :data:`KIND_SYNTHETIC`).
    protect
        Paths that must not lie inside what is replaced (the scan, the annotations; ``None`` entries
        are skipped); the working directory is always protected.

    Returns
    -------
    Path
        The directory to write: ``target`` made absolute, through a symbolic link if it is one.
    """
    given = Path(target)
    if str(target) == "" or given.name in ("", ".", "..") or str(given).endswith(os.sep):
        given = Path(os.path.abspath(given))
    if given.is_symlink():
        if not given.exists():
            raise OutputError(f"{given}: is a symbolic link to nothing", "choose another output path with -o, or remove the link")
        given = Path(os.path.realpath(given))
    t = given
    if t.exists() and not t.is_dir():
        raise OutputError(f"{t}: exists and is not a directory", "choose another output path with -o")
    if t.exists() and not force:
        raise OutputError(f"{t}: output directory already exists", "pass --force to replace it, or choose another with -o")
    if t.exists():
        _check_replaceable(t, kind, protect)
    probe = t.parent
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"{t}: cannot write there: {probe} is a file, not a directory", "choose another output path with -o")
    limit = _name_max(probe)
    if len(os.fsencode(t.name)) + _STAGING_NAME_EXTRA > limit:
        raise OutputError(
            f"{t.name[:40]}...: output name too long ({len(os.fsencode(t.name))} bytes; this file system takes "
            f"{limit} and meshplan needs {_STAGING_NAME_EXTRA} of them for its staging name)",
            "choose a shorter output name with -o",
        )
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
def staged_directory(
    target: str | os.PathLike, force: bool = False, *, kind: str = KIND_PLANS, protect: Iterable[str | os.PathLike | None] = ()
) -> Iterator[Path]:
    """Yield an empty hidden directory; on success it is stamped as meshplan's (``kind``) and
    replaces ``target`` in one rename.

    On any exception the staged directory is deleted and ``target`` is left as it was. ``force``,
    ``kind`` and ``protect`` are those of :func:`check_output_dir`.
    """
    t = check_output_dir(target, force, kind=kind, protect=protect)
    # from here Ctrl-C cleans up what was created (the program exited at once until now: see
    # meshplan._ctrl_c)
    raise_from_now()
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
            write_stamp(tmp, kind)
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
