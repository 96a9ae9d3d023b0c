"""The ``meshplan`` command line: a thin layer over :func:`meshplan.run` and friends.

Every user error is printed as one line, ``error: <problem>; <what to do>``, with exit status 2
and no traceback. Progress goes to stderr (``--quiet`` silences it); ``--json`` prints the
summary as JSON on stdout. Running out of memory is reported the same way; any other exception is
a bug in meshplan, reported in one line with exit status 1 (the traceback with ``-v``).

Why one long module: each command's options are its documentation (typer reads them from the
signatures, with the defaults from the stages' parameter classes), and :func:`main`'s one-line
error handling wraps every command; the shared scan options are declared once (:data:`_SCAN_OPTIONS`).
"""

from __future__ import annotations

import functools
import inspect
import json
import logging
import os
import signal
import sys
import threading
from collections.abc import Callable
from enum import Enum
from pathlib import Path
from typing import Any, Optional

#: Loading as the ``meshplan`` program (the console script or ``python -m meshplan``).
_PROGRAM = bool(sys.argv[:1]) and (Path(sys.argv[0]).name == "meshplan" or Path(sys.argv[0]).parts[-2:] == ("meshplan", "__main__.py"))
#: ... with Python's own Ctrl-C handler; a library importing this module keeps its handler, and
#: a program started with Ctrl-C ignored (``nohup``, a shell's background job) keeps ignoring it.
_STARTING = _PROGRAM and threading.current_thread() is threading.main_thread() and signal.getsignal(signal.SIGINT) is signal.default_int_handler
if _STARTING:
    # Ctrl-C while this module loads (typer, and the options' defaults, which import numpy and
    # scipy: about a second), before main() can catch it: the same one line, no traceback
    from ._ctrl_c import exit_at_once

    signal.signal(signal.SIGINT, exit_at_once)
if _PROGRAM:
    from ._memory import keep_freed_memory, pause_collector, small_pages

    keep_freed_memory()  # before numpy allocates: every array of the run reuses freed memory
    small_pages()  # before numpy loads: its large arrays in small pages (see meshplan._memory)
    pause_collector()  # until the libraries are loaded (resume_collector; see meshplan._memory)

import typer  # noqa: E402 - after the handler above: this import takes a while

from . import __version__  # noqa: E402
from .errors import MeshplanError, ParameterError  # noqa: E402

app = typer.Typer(
    name="meshplan",
    help="Turn a scanned triangle mesh of a building interior into an oriented 3D model and floor plans.",
    add_completion=False,
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,
)


class Up(str, Enum):
    auto = "auto"
    px = "+x"
    nx = "-x"
    py = "+y"
    ny = "-y"
    pz = "+z"
    nz = "-z"


class Units(str, Enum):
    m = "m"
    cm = "cm"
    mm = "mm"
    ft = "ft"
    inch = "in"


class Gravity(str, Enum):
    kmeans = "kmeans"
    bbox = "bbox"


class Directions(str, Enum):
    auto = "auto"
    principal = "principal"
    all = "all"


def _d(name: str, text: str) -> str:
    """Help text with the parameter's default, read from the stage that owns it."""
    from .options import RunOptions

    opts = RunOptions()
    value = getattr(getattr(opts, RunOptions.names()[name]), name)
    return f"{text} [default: {value:g}]" if isinstance(value, float) else f"{text} [default: {value}]"


def _version(value: bool) -> None:
    if value:
        typer.echo(f"meshplan {__version__}")
        raise typer.Exit()


#: The options of ``run`` that apply to every scan of a ``batch`` as well, declared once:
#: (command-line parameter, its type, the keyword of :func:`meshplan.run`, the typer option).
#: :func:`_scan_options` adds them to both commands.
_SCAN_OPTIONS: tuple[tuple[str, str, str, Any], ...] = (
    ("units", "Optional[Units]", "units", typer.Option(None, "--units", help=_d("units", "Unit of the scan's coordinates."))),
    ("up", "Optional[Up]", "up", typer.Option(None, "--up", help=_d("up", "Input axis that is roughly up, or auto."))),
    (
        "gravity",
        "Optional[Gravity]",
        "gravity_method",
        typer.Option(None, "--gravity", help=_d("gravity_method", "kmeans (paper's Method 2) or bbox (Method 1).")),
    ),
    ("slices", "Optional[int]", "slices", typer.Option(None, "--slices", help=_d("slices", "Slicing intervals of the pen-and-ink plan (n + 1 planes)."))),
    ("opacity", "Optional[float]", "opacity", typer.Option(None, "--opacity", help=_d("opacity", "Opacity of each pen-and-ink slice."))),
    ("imperial", "Optional[bool]", "imperial", typer.Option(None, "--imperial/--metric", help=_d("imperial", "Scale bars and areas in feet (or metres)."))),
    ("scale", "Optional[int]", "scale", typer.Option(None, "--scale", help=_d("scale", "Drawing scale 1:N (0 = automatic)."))),
    ("dpi", "Optional[int]", "dpi", typer.Option(None, "--dpi", help=_d("dpi", "PNG resolution (dots per inch)."))),
    (
        "sheet",
        "Optional[str]",
        "sheet",
        typer.Option(None, "--sheet", help=_d("sheet", "Paper: A4-A0, Letter, Tabloid, ANSI-B, Arch-D, auto (smallest that fits) or fit (a fitted page).")),
    ),
    (
        "drafting_height",
        "Optional[float]",
        "drafting_height_m",
        typer.Option(None, "--drafting-height", help=_d("drafting_height_m", "Cut height of the drafting plan above the floor (m).")),
    ),
    (
        "box_length",
        "Optional[float]",
        "box_length_m",
        typer.Option(None, "--box-length", help=_d("box_length_m", "DBSCAN box along the wall (m; paper: 1.5 ft).")),
    ),
    (
        "box_depth",
        "Optional[float]",
        "box_depth_m",
        typer.Option(None, "--box-depth", help=_d("box_depth_m", "DBSCAN box across the wall (m; paper: a few inches).")),
    ),
    (
        "box_height",
        "Optional[float]",
        "box_height_m",
        typer.Option(None, "--box-height", help="DBSCAN box height (m) [default: the story's floor-to-ceiling height]."),
    ),
    ("min_points", "Optional[int]", "min_points", typer.Option(None, "--min-points", help=_d("min_points", "DBSCAN minimum points in a box."))),
    (
        "wall_directions",
        "Optional[Directions]",
        "wall_directions",
        typer.Option(None, "--wall-directions", help=_d("wall_directions", "principal (k = 4), all, or auto.")),
    ),
    (
        "min_wall_length",
        "Optional[float]",
        "min_wall_length_m",
        typer.Option(None, "--min-wall-length", help=_d("min_wall_length_m", "Shortest flat wall kept (m).")),
    ),
    (
        "floor_reach",
        "Optional[float]",
        "floor_reach_m",
        typer.Option(None, "--floor-reach", help=_d("floor_reach_m", "A wall must come this close to the floor (m).")),
    ),
    (
        "ceiling_reach",
        "Optional[float]",
        "ceiling_reach_m",
        typer.Option(None, "--ceiling-reach", help=_d("ceiling_reach_m", "A wall must come this close to the ceiling (m).")),
    ),
    (
        "min_room_height",
        "Optional[float]",
        "min_room_height_m",
        typer.Option(None, "--min-room-height", help=_d("min_room_height_m", "Smallest floor-to-ceiling gap of a story (m).")),
    ),
    (
        "default_ceiling_height",
        "Optional[float]",
        "default_ceiling_height_m",
        typer.Option(None, "--default-ceiling-height", help=_d("default_ceiling_height_m", "Ceiling height assumed when none is scanned (m).")),
    ),
    ("ifc", "bool", "ifc", typer.Option(False, "--ifc", help="Also write model.ifc (IFC4; needs the ifc extra).")),
    ("gbxml", "bool", "gbxml", typer.Option(False, "--gbxml", help="Also write model.gbxml (gbXML 7.03 energy model: a space and zone per room).")),
    ("idf", "bool", "idf", typer.Option(False, "--idf", help="Also write model.idf (EnergyPlus, translated by OpenStudio; needs the energy extra).")),
    ("osm", "bool", "osm", typer.Option(False, "--osm", help="Also write model.osm (OpenStudio model; needs the energy extra).")),
    (
        "site_lat",
        "Optional[float]",
        "site_lat_deg",
        typer.Option(None, "--site-lat", help=_d("site_lat_deg", "Site latitude of the energy model (degrees north; Chicago O'Hare).")),
    ),
    (
        "site_lon",
        "Optional[float]",
        "site_lon_deg",
        typer.Option(None, "--site-lon", help=_d("site_lon_deg", "Site longitude of the energy model (degrees east).")),
    ),
    (
        "north_deg",
        "Optional[float]",
        "north_deg",
        typer.Option(None, "--north-deg", help=_d("north_deg", "Compass bearing of plan -z, up the page (degrees clockwise from north; 0: plan +z is south).")),
    ),
    ("max_faces", "Optional[int]", "max_faces", typer.Option(None, "--max-faces", help="Refuse larger scans [default: what fits in memory].")),
    ("set_", "list[str]", "", typer.Option([], "--set", help="Any other parameter, NAME=VALUE (see plan.json 'parameters').")),
)
#: Flags that are given (True) or left to the parameter's default (False is "not given").
_FLAGS = frozenset({"ifc", "gbxml", "idf", "osm"})


def _scan_options(command: Callable[..., None]) -> Callable[..., None]:
    """``command`` with the :data:`_SCAN_OPTIONS` added to its signature (typer reads it); the
    command receives them as ``**options``, and :func:`_run_keywords` maps them to
    :func:`meshplan.run`'s keywords, so that ``run`` and ``batch`` cannot drift apart."""
    sig = inspect.signature(command)
    own = [p for p in sig.parameters.values() if p.kind is not inspect.Parameter.VAR_KEYWORD]
    added = [inspect.Parameter(name, inspect.Parameter.POSITIONAL_OR_KEYWORD, default=option, annotation=ann) for name, ann, _, option in _SCAN_OPTIONS]

    @functools.wraps(command)
    def with_options(**given: Any) -> None:
        command(**given)

    # after the command's own inputs and options, before how it reports (--quiet, --json, -v)
    at = next((i for i, p in enumerate(own) if p.name == "quiet"), len(own))
    with_options.__signature__ = sig.replace(parameters=own[:at] + added + own[at:])  # type: ignore[attr-defined]
    with_options.__annotations__ = {**command.__annotations__, **{name: ann for name, ann, _, _ in _SCAN_OPTIONS}}
    return with_options


def _run_keywords(options: dict[str, Any]) -> dict[str, Any]:
    """The :data:`_SCAN_OPTIONS` given on the command line (choices as their values, unset ones
    left out) and the ``--set NAME=VALUE`` ones, as keywords of :func:`meshplan.run`."""
    keyword = {name: kw for name, _, kw, _ in _SCAN_OPTIONS}
    params = {
        keyword[k]: getattr(v, "value", v) for k, v in options.items() if k != "set_" and v is not None and not (k in _FLAGS and v is False)
    }
    params.update(_parse_set(options.get("set_", [])))
    return params


@app.callback()
def _main(
    ctx: typer.Context,
    version: bool = typer.Option(False, "--version", callback=_version, is_eager=True, help="Print the version and exit."),
) -> None:
    """meshplan: scanned mesh in, oriented model and floor plans out."""
    if ctx.invoked_subcommand != "run":  # run resumes it once it has loaded its libraries
        _resume_collector()


def _resume_collector() -> None:
    """The garbage collector back on, if the program paused it while loading
    (:func:`meshplan._memory.pause_collector`)."""
    from ._memory import resume_collector

    resume_collector()


def _parse_set(items: list[str]) -> dict[str, Any]:
    """``NAME=VALUE`` pairs, values parsed as JSON when they can be (numbers, true, lists)."""
    out: dict[str, Any] = {}
    for item in items:
        if "=" not in item:
            raise ParameterError(f"--set {item!r} is not NAME=VALUE", "write e.g. --set gravity_plane_fit=false")
        name, value = item.split("=", 1)
        try:
            parsed = json.loads(value)
        except json.JSONDecodeError:  # a word: the parameter's validator says whether it fits
            parsed = value
        except (ValueError, RecursionError):  # a number of over 4,300 digits, lists nested too deep
            raise ParameterError(
                f"--set {name.strip()}: the value cannot be read (nested too deeply, or a number of more than 4,300 digits)",
                "give a number, true/false, a word or a short list",
            ) from None
        out[name.strip().replace("-", "_")] = tuple(parsed) if isinstance(parsed, list) else parsed
    return out


def _setup_logging(verbose: int, quiet: bool) -> None:
    """Warnings and errors on stderr; ``-v`` adds meshplan's debug records, ``-vv`` every
    library's (matplotlib, trimesh, ... are too chatty for ``-v``); ``--quiet`` only errors."""
    level = logging.ERROR if quiet else logging.DEBUG if verbose >= 2 else logging.WARNING
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s", stream=sys.stderr, force=True)
    # reset on every call: main() may run several commands in one process
    logging.getLogger("meshplan").setLevel(logging.DEBUG if verbose and not quiet else logging.NOTSET)


@app.command()
@_scan_options
def run(
    scan: Path = typer.Argument(
        ...,
        help="Scan: a mesh (OBJ, PLY, GLB/glTF, STL, OFF), a point cloud (E57, LAS/LAZ, PLY or OBJ without faces, "
        "XYZ/PTS/TXT; the points extra) or a USD stage (USD/USDA/USDC/USDZ, RoomPlan, Polycam; the usd extra).",
    ),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Output directory [default: ./meshplan-out/<scan name>]."),
    annotations: Optional[Path] = typer.Option(None, "--annotations", "-a", help="Annotations JSON (input coordinates)."),
    rooms: Optional[Path] = typer.Option(
        None, "--rooms", help="rooms.json (or a previous plan.json) whose room numbers, names and types carry over, matched by position."
    ),
    force: bool = typer.Option(False, "--force", "-f", help="Replace an existing output directory."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON on stdout."),
    verbose: int = typer.Option(0, "--verbose", "-v", count=True, help="Debug logging (-vv: also the libraries')."),
    **options: Any,
) -> None:
    """Orient a scan, split it into stories and draw its floor plans."""
    from ._ctrl_c import exit_at_once_from_now

    if _STARTING:  # the program: Ctrl-C ends the run at once until it writes (meshplan._ctrl_c)
        exit_at_once_from_now()
    from . import api
    from ._kernels import load_machinery

    # numba's compiler machinery, which the run's first stage loads anyway, loaded now: with
    # the libraries, while the collector is paused (meshplan._memory), then the collector back
    load_machinery()
    _resume_collector()
    _setup_logging(verbose, quiet)
    params = _run_keywords(options)
    out = output if output is not None else api.default_output_dir(scan)
    from .progress import StageProgress

    with StageProgress(enabled=not quiet and not as_json) as progress:
        extra: dict[str, Any] = {"rooms": rooms} if rooms is not None else {}  # given only when used
        result = api.run(scan, annotations=annotations, output=out, force=force, progress=progress.update, **extra, **params)
    if as_json:
        # the summary on stdout holds them; stderr says them too (as log warnings)
        for w in result.warnings:
            logging.getLogger("meshplan").warning(w)
        typer.echo(json.dumps({**result.summary(), "envelope": _envelope(result)}, indent=2))
    elif not quiet:
        from .progress import print_summary

        print_summary(result)  # with the warnings, once
        _print_envelope(result)


def _envelope(result: Any) -> dict[str, Any]:
    """The envelope summary of the summary (plan.json's ``envelope``, per orientation and in total)."""
    from .export.gbxml import envelope_summary

    env = envelope_summary(result, 2)
    return {k: env[k] for k in ("north_deg", "orientations", "total")}


def _print_envelope(result: Any) -> None:
    """One line per facade orientation: exterior wall and window areas, window-to-wall ratio."""
    env = _envelope(result)
    parts = [
        f"{o['orientation']} {o['wall_area']:.1f} m2 wall, {o['window_area']:.1f} m2 window, WWR {o['wwr']:.2f}" for o in env["orientations"] if o["walls"]
    ]
    if parts:
        typer.echo(f"envelope (north {env['north_deg']:g} deg): " + "; ".join(parts), err=True)


@app.command()
def synth(
    output: Path = typer.Option(..., "--output", "-o", help="Directory to write the scan, annotations.json and truth.json to."),
    preset: str = typer.Option("apartment", "--preset", help="room, apartment, office or multistory."),
    seed: int = typer.Option(0, "--seed", help="Random seed (same seed, same scan)."),
    fmt: str = typer.Option("obj", "--format", help="Scan file format: obj, ply, glb, stl or off."),
    stories: Optional[int] = typer.Option(None, "--stories", help="Stories of the multistory preset (2 or 3)."),
    target_faces: Optional[int] = typer.Option(None, "--target-faces", help="Aim at about this many faces."),
    z_up: bool = typer.Option(False, "--z-up", help="Write the scan z-up."),
    tilt: Optional[float] = typer.Option(None, "--tilt", help="Tilt in degrees [default: random up to 6]."),
    yaw: Optional[float] = typer.Option(None, "--yaw", help="Yaw in degrees [default: random]."),
    force: bool = typer.Option(False, "--force", "-f", help="Replace an existing output directory."),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but errors."),
) -> None:
    """Write a synthetic scan with exact ground truth (for tests, benchmarks and demos)."""
    from .export.synth import write_synthetic
    from .synthetic import SynthParams, generate

    kw: dict[str, Any] = dict(preset=preset, seed=seed, z_up=z_up)
    for k, v in (("stories", stories), ("target_faces", target_faces), ("tilt_deg", tilt), ("yaw_deg", yaw)):
        if v is not None:
            kw[k] = v
    scan = generate(SynthParams(**kw))
    path = write_synthetic(scan, output, fmt, force=force)
    if not quiet:
        typer.echo(f"wrote {path} ({scan.mesh.n_faces:,} faces), {output / 'annotations.json'} and {output / 'truth.json'}")


@app.command()
def evaluate(
    plan: Path = typer.Argument(..., help="plan.json written by meshplan run."),
    truth: Path = typer.Argument(..., help="truth.json written by meshplan synth."),
    as_json: bool = typer.Option(False, "--json", help="Print the report as JSON."),
    output: Optional[Path] = typer.Option(None, "--output", "-o", help="Also write the JSON report to this file."),
) -> None:
    """Compare a result with a synthetic scan's ground truth (the paper's Table 2 and more)."""
    from .evaluate import evaluate as run_evaluation
    from .evaluate import format_report
    from .io import atomic_write_text

    docs = []
    for path, what in ((plan, "plan"), (truth, "truth")):
        try:
            docs.append(json.loads(path.read_text(encoding="utf-8")))
        except FileNotFoundError:
            raise MeshplanError(f"{path}: file not found", f"give the {what} JSON file") from None
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise MeshplanError(f"{path}: not a readable JSON file ({exc})", f"give the {what} JSON file") from None
    report = run_evaluation(*docs)
    text = json.dumps(report, indent=2)
    if output is not None:
        atomic_write_text(output, text + "\n")
    typer.echo(text if as_json else format_report(report))


@app.command()
def schema() -> None:
    """Print the JSON Schema of plan.json."""
    from .export import plan_schema

    typer.echo(json.dumps(plan_schema(), indent=2))


@app.command()
@_scan_options
def batch(
    inputs: list[str] = typer.Argument(..., help="Directories of scans (searched recursively), glob patterns (quote them) or scan files."),
    output: Path = typer.Option(..., "--output", "-o", help="Batch directory: one directory per scan, plus summary.csv and summary.json. May exist."),
    workers: int = typer.Option(1, "--workers", "-j", help="Scans processed at once by local worker processes (0 = one per core)."),
    scheduler: Optional[str] = typer.Option(
        None, "--scheduler", help="Run on a Dask cluster at this address (tcp://host:port); its workers must see the same files at the same paths."
    ),
    force: bool = typer.Option(False, "--force", "-f", help="Replace existing per-scan directories (else those scans fail and keep their old results)."),
    annotations: Optional[str] = typer.Option(
        None, "--annotations", "-a",
        help=(
            "Annotations of each scan, relative to its directory, {stem} standing for the scan's name "
            "(e.g. '{stem}-sensors.json') [default: <stem>.annotations.json, else annotations.json]."
        ),
    ),
    exclude: list[str] = typer.Option(
        [], "--exclude", "-x", help="Glob pattern of files that are not scans, on the name or the path (repeatable; e.g. '*.su_planes.ply')."
    ),
    quiet: bool = typer.Option(False, "--quiet", "-q", help="Print nothing but the failed scans' errors."),
    as_json: bool = typer.Option(False, "--json", help="Print the summary as JSON on stdout."),
    verbose: int = typer.Option(0, "--verbose", "-v", count=True, help="Debug logging (-vv: also the libraries')."),
    **options: Any,
) -> None:
    """Run many scans, one output directory each, and summarize them.

    Scans run in parallel across --workers (each scan draws in its own worker; --set
    processes=N changes that). Annotations are taken from <scan stem>.annotations.json or annotations.json beside each scan.
    A scan that fails is reported and skipped; the others go on. Exit status: 0 when every scan
    succeeded, 1 when some failed (see summary.csv), 2 for a usage error (no scans found, bad
    option, unwritable output, no Dask scheduler).
    """
    from .batch import BatchInterrupted, ScansFailed, find_annotations, find_scans, run_batch
    from .progress import BatchProgress, print_batch_summary

    _setup_logging(verbose, quiet)
    params = _run_keywords(options)
    # several inputs (e.g. an unquoted glob the shell expanded) are concatenated, duplicates dropped
    scans = list(dict.fromkeys(p for spec in inputs for p in find_scans(spec, exclude=output, skip=exclude)))
    if not scans:
        raise MeshplanError(f"every scan given matches --exclude ({', '.join(exclude)})", "check the inputs and the --exclude patterns")
    jobs = [(s, find_annotations(s, annotations)) for s in scans]
    try:
        with BatchProgress(enabled=not quiet and not as_json) as bar:
            summary = run_batch(jobs, output, workers=workers, scheduler=scheduler, force=force, progress=bar.update, **params)
    except KeyboardInterrupt:
        raise BatchInterrupted("interrupted", f"the finished scans are in {output} (see summary.csv)") from None
    if as_json:
        typer.echo(json.dumps(summary.to_dict(), indent=2))
    elif not quiet:
        print_batch_summary(summary)
    if quiet:
        for row in summary.failed:
            typer.echo(f"error: {row.scan}: {row.error}", err=True)
    if summary.failed:  # exit status 1 (main() prints the message)
        raise ScansFailed(f"{len(summary.failed)} of {len(summary.rows)} scans failed", f"see {output / 'summary.csv'}")


def _usage_error_types() -> tuple[type[BaseException], ...]:
    """Command-line usage errors of typer, which ships its own copy of click (from 0.29 on:
    ``typer.TyperException`` is the base of its ``ClickException``); plain click is not a
    dependency of meshplan, so it is not imported."""
    return (typer.TyperException,)


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``meshplan`` console script; returns the exit status."""
    try:
        status = app(args=argv, prog_name="meshplan", standalone_mode=False)
    except MeshplanError as exc:
        typer.echo(f"error: {exc.message}", err=True)
        return exc.exit_code
    except typer.Exit as exc:
        return int(getattr(exc, "exit_code", 0) or 0)
    except (KeyboardInterrupt, typer.Abort):
        typer.echo("error: interrupted; nothing was written", err=True)
        return 130
    except _usage_error_types() as exc:
        if type(exc).__name__.startswith("NoArgsIsHelp"):
            ctx = getattr(exc, "ctx", None)
            typer.echo(ctx.get_help() if ctx is not None else "usage: meshplan COMMAND --help")
            return 0
        message = exc.format_message() if hasattr(exc, "format_message") else str(exc)
        message = " ".join(str(message).split()).replace("Value error, ", "").rstrip(".")
        ctx = getattr(exc, "ctx", None)
        cmd = ctx.command_path if ctx is not None else "meshplan"
        typer.echo(f"error: {message}; see '{cmd} --help'", err=True)
        return 2
    except MemoryError:
        # the up-front estimate (io.mesh.BYTES_PER_FACE) was too low, or --max-faces overrode it
        typer.echo("error: ran out of memory while processing the scan; decimate the scan or free memory, "
                   "and leave --max-faces unset so that such scans are refused up front", err=True)
        return 2
    except Exception as exc:  # a bug in meshplan: still one line; the traceback with -v
        if logging.getLogger("meshplan").isEnabledFor(logging.DEBUG):
            import traceback

            traceback.print_exc()
        detail = " ".join(str(exc).split())[:200]
        typer.echo(f"error: internal error ({type(exc).__name__}{': ' + detail if detail else ''}); "
                   "please report this bug in meshplan with the scan and the command (add -v for the traceback)", err=True)
        return 1
    if status == 130:  # typer turns Ctrl-C into Exit(130), which it returns outside standalone mode
        typer.echo("error: interrupted; nothing was written", err=True)
    return status if isinstance(status, int) else 0


def entry() -> None:  # pragma: no cover - exercised through the console script in the tests
    """The ``meshplan`` console script and ``python -m meshplan``: :func:`main`, then a quick
    exit. Every file is written and renamed into place when :func:`main` returns; tearing the
    interpreter down afterwards (numba's compiler, matplotlib, hundreds of thousands of objects)
    would add about half a second to every run, so the process ends at once after flushing."""
    status = main()
    logging.shutdown()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe: nothing more to say
            pass
    os._exit(status)


if _STARTING:  # loaded: from here on main() reports a Ctrl-C
    signal.signal(signal.SIGINT, signal.default_int_handler)

if __name__ == "__main__":  # pragma: no cover
    entry()
