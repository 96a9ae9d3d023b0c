"""Finding the scans of a batch, their annotations, and one output directory name per scan
(see :mod:`meshplan.batch`, "Discovery" and "Output layout")."""

from __future__ import annotations

import fnmatch
import glob
import os
from collections.abc import Sequence
from pathlib import Path

from ..errors import MeshplanError
from ..io import SCAN_FORMATS, is_scan_file
from .summary import SUMMARY_FILES

__all__ = ["DEFAULT_ANNOTATION_PATTERNS", "find_annotations", "find_scans", "output_names"]


def _mesh_file(path: Path) -> bool:
    """A scan by its extension (meshes, point clouds, USD: :data:`meshplan.io.SCAN_FORMATS`);
    a ``.txt`` only when it holds points."""
    return is_scan_file(path)


def _formats() -> str:
    return ", ".join(sorted(SCAN_FORMATS))


def _inside(path: Path, folder: Path | None) -> bool:
    if folder is None:
        return False
    try:
        return Path(os.path.abspath(path)).is_relative_to(Path(os.path.abspath(folder)))
    except (OSError, ValueError):
        return False


def _excluded(path: Path, patterns: Sequence[str]) -> bool:
    """Whether ``path`` matches one of the glob ``patterns``, by its file name
    (``*.su_planes.ply``) or by its whole path (``*/old/*``)."""
    text = path.as_posix()
    return any(fnmatch.fnmatch(path.name, pat) or fnmatch.fnmatch(text, pat) for pat in patterns)


def find_scans(
    spec: str | os.PathLike, *, exclude: str | os.PathLike | None = None, skip: Sequence[str] = ()
) -> list[Path]:
    """The scan files a batch input names.

    Parameters
    ----------
    spec
        A directory (searched recursively for files with a mesh extension, hidden files and
        directories skipped), a glob pattern (``**`` allowed; only files with a mesh extension
        are kept), or a single mesh file.
    exclude
        A directory whose contents are never taken as scans (the batch's output directory).
    skip
        Glob patterns of files that are not scans although they have a mesh extension, matched
        against the file name or the path (e.g. ``*.su_planes.ply``, the HoloLens 2 plane
        sidecars).

    Returns
    -------
    list of Path
        The scans, sorted (a glob's matches and a directory's files both in path order), as
        paths relative to the same place as ``spec``.

    Raises
    ------
    MeshplanError
        When nothing matches (one line: the problem; what to do).
    """
    text = os.fspath(spec)
    path = Path(text)
    excl = Path(exclude) if exclude is not None else None
    if path.is_dir():
        found: list[Path] = []
        for root, dirs, files in os.walk(path):
            # skip hidden directories (e.g. half-written results) and the batch's own output
            dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not _inside(Path(root, d), excl))
            found.extend(Path(root, f) for f in files if not f.startswith(".") and _mesh_file(Path(root, f)))
        found = sorted(p for p in found if not _inside(p, excl) and not _excluded(p, skip))
        if not found:
            raise MeshplanError(
                f"{text}: no scan files ({_formats()}) in this directory or below",
                "put the scans in it, or give a glob pattern such as 'scans/**/*.ply'",
            )
        return found
    if path.is_file():
        if _excluded(path, skip):
            return []
        if not _mesh_file(path):
            raise MeshplanError(f"{text}: not a mesh file ({_formats()})", "give a directory of scans, a glob pattern or a mesh file")
        return [path]
    if glob.has_magic(text):
        matches = sorted({Path(m) for m in glob.glob(text, recursive=True)})
        found = [p for p in matches if p.is_file() and _mesh_file(p) and not _inside(p, excl) and not _excluded(p, skip)]
        if not found:
            what = f"matches {len(matches)} files but none is a scan ({_formats()})" if matches else "matches no file"
            raise MeshplanError(f"{text!r} {what}", "check the pattern (quote it so that the shell does not expand it)")
        return found
    raise MeshplanError(f"{text}: no such directory or file", "give a directory of scans or a glob pattern such as 'scans/**/*.obj'")


#: Where a scan's annotations are looked for when no pattern is given, in this order.
DEFAULT_ANNOTATION_PATTERNS = ("{stem}.annotations.json", "annotations.json")


def find_annotations(scan: str | os.PathLike, pattern: str | None = None) -> Path | None:
    """The annotations of a scan.

    Parameters
    ----------
    scan
        The scan file.
    pattern
        A file name or path relative to the scan's directory in which ``{stem}`` stands for the
        scan's file name without its extension (``{stem}-sensors.json``, ``../ann/{stem}.json``).
        ``None``: ``<stem>.annotations.json`` beside the scan, else ``annotations.json``.

    Returns
    -------
    Path or None
        The first candidate that is a file, or ``None``.
    """
    p = Path(scan)
    patterns = DEFAULT_ANNOTATION_PATTERNS if pattern is None else (pattern,)
    for candidate in (p.parent / pat.replace("{stem}", p.stem) for pat in patterns):
        if candidate.is_file():
            return candidate
    return None


def output_names(scans: Sequence[str | os.PathLike]) -> list[str]:
    """One distinct directory name per scan, from the file names (see the module docstring).

    Deterministic: depends only on the list. Names are compared case-insensitively (for
    case-insensitive file systems) and never equal a summary file's name.
    """
    paths = [Path(os.path.abspath(s)) for s in scans]

    def name(p: Path, depth: int, ext: bool = False) -> str:
        parents = [q for q in p.parent.parts if q not in ("/", p.anchor)]
        parts = [*parents[len(parents) - depth :]] if depth else []
        stem = p.stem.lstrip(".") or "scan"  # a leading dot would hide the directory
        parts.append(f"{stem}-{p.suffix.lstrip('.').lower()}" if ext else stem)
        return "-".join(s.replace(os.sep, "-") for s in parts)

    names = [name(p, 0) for p in paths]
    groups: dict[str, list[int]] = {}
    for i, n in enumerate(names):
        groups.setdefault(n.casefold(), []).append(i)
    for members in groups.values():
        if len(members) < 2:
            continue
        # fewest parent directories that tell the group's scans apart
        deepest = max(len(paths[i].parent.parts) for i in members)
        depth = next(
            (d for d in range(1, deepest + 1) if len({name(paths[i], d).casefold() for i in members}) == len(members)),
            deepest,
        )
        cand = {i: name(paths[i], depth) for i in members}
        counts: dict[str, int] = {}
        for n in cand.values():
            counts[n.casefold()] = counts.get(n.casefold(), 0) + 1
        for i in members:
            # same directory and stem: the extension tells them apart
            names[i] = name(paths[i], depth, ext=True) if counts[cand[i].casefold()] > 1 else cand[i]
    # whatever still collides (the same file twice, a name made equal to another): -2, -3, ...
    taken = {f.casefold() for f in SUMMARY_FILES}
    out: list[str] = []
    for n in names:
        unique, k = n, 1
        while unique.casefold() in taken:
            k += 1
            unique = f"{n}-{k}"
        taken.add(unique.casefold())
        out.append(unique)
    return out
