"""report.html: one self-contained page with everything a run made, and an annotation editor.

The page is a Jinja2 template (``templates/report.html.j2``, autoescape on) filled from the
result; this module gathers what it shows, the 3D view's data comes from
:mod:`meshplan.export.view3d`. The page works offline and makes no network request: plotly's
bundle, the style sheet and the script are inlined, the plans are inline SVG and the diagnostic
figures ``data:`` URIs. It shows

* the oriented 3D model of each story without its ceiling, the flat walls and the annotations,
  each a layer (plotly legend), rotatable and zoomable; large scans are shown simplified, by
  vertex clustering on the finest voxel grid that fits the page's budget of faces (no holes:
  :func:`~meshplan.export.view3d.view_meshes`), and the page says so;
* the pen-and-ink and drafting plans of each story, with the rooms (and openings) of plan.json
  when it has them;
* the altitude histogram and the normals heat map;
* the timings beside the paper's, every parameter, the input statistics and the warnings.

In the browser a user places annotations as the paper's users do with a HoloLens: a click on
the model picks the exact point of the shown face under the cursor (a ray cast in the page, so
the point lies on the scanned surface, not on the nearest vertex) and its normal, turned towards
the viewer, as the probe direction. "Export annotations.json" writes them in the input
coordinates and units of the scan, ready for ``meshplan run --annotations``.

Apart from the timing values, the same result always gives the same page (no timestamps, no
random ids; the simplification is deterministic).
"""

from __future__ import annotations

import base64
import html
import json
import re
from functools import lru_cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np
from markupsafe import Markup

from .._version import __version__
from ..geometry import ANNOTATION_KINDS
from ..result import PAPER_FACES, PAPER_TIMINGS_S, STAGES
from .planjson import plan_document
from .view3d import KIND_PREFIX, MAX_FACES, PROBE_M, SUBSAMPLE_SEED, ViewMesh, ViewMeshes, page_data, simplify_faces, subsample_faces, view_meshes

if TYPE_CHECKING:  # pragma: no cover
    import jinja2

    from ..result import Result

# ViewMesh, ViewMeshes, simplify_faces, subsample_faces and view_meshes live in view3d; named here as before
__all__ = [
    "KIND_PREFIX", "MAX_FACES", "PROBE_M", "SUBSAMPLE_SEED", "ViewMesh", "ViewMeshes", "inline_svg", "report_html", "report_page",
    "simplify_faces", "subsample_faces", "view_meshes",
]

_ID = re.compile(r'\bid="([^"]+)"')
_REF = re.compile(r'(href="#|url\(#)([^")]+)')


def inline_svg(data: bytes, prefix: str, title: str) -> Markup:
    """An SVG file (as matplotlib writes it) as an element to put in the page.

    The XML prologue and metadata go; every id gets ``prefix`` (matplotlib numbers its ids
    the same way in every figure, so two plans in one page would otherwise share them, and a
    reference could draw the other plan's marker), and the drawing scales to its box. The
    SVG is meshplan's own drawing, put in the page as it is (the only markup the template takes
    unescaped, with the style sheet, the scripts and the page's data).
    """
    text = data.decode("utf-8")
    text = text[text.find("<svg") :]
    text = re.sub(r"<metadata>.*?</metadata>\s*", "", text, flags=re.S)
    ids = set(_ID.findall(text))
    text = _ID.sub(lambda m: f'id="{prefix}-{m.group(1)}"', text)
    text = _REF.sub(lambda m: m.group(1) + (f"{prefix}-{m.group(2)}" if m.group(2) in ids else m.group(2)), text)
    head_end = text.find(">")
    head = text[:head_end]
    head = re.sub(r'\s(width|height)="[^"]*"', "", head)
    head += f' class="plan-svg" role="img" aria-label="{html.escape(title)}"'
    return Markup(head + text[head_end:])


def _escape(value: Any) -> Any:
    """Every value the template prints, escaped as :func:`html.escape` does (quotes too):
    markup made here (:class:`~markupsafe.Markup`) passes unchanged."""
    if hasattr(value, "__html__"):
        return value
    return Markup(html.escape(str(value)))


@lru_cache(maxsize=1)
def _environment() -> jinja2.Environment:
    import jinja2

    return jinja2.Environment(
        loader=jinja2.PackageLoader("meshplan.export", "templates"),
        autoescape=True,
        finalize=_escape,
        keep_trailing_newline=True,
        undefined=jinja2.StrictUndefined,
    )


def _num(v: Any, nd: int = 3) -> str:
    if isinstance(v, bool) or v is None:
        return "—" if v is None else str(v).lower()
    if isinstance(v, (int, np.integer)):
        return f"{int(v):,}"
    if isinstance(v, (float, np.floating)):
        return f"{float(v):,.{nd}f}"
    return str(v)


def _generic_table(items: list[dict[str, Any]]) -> dict[str, Any]:
    """A table of JSON objects, one column per scalar field (and short vectors)."""
    cols: list[str] = []
    for item in items:
        for k, v in item.items():
            short = isinstance(v, list) and len(v) <= 3 and all(isinstance(c, (int, float)) for c in v)
            if k not in cols and (short or isinstance(v, (str, int, float, bool)) or v is None):
                cols.append(k)
    rows = []
    for item in items:
        row = []
        for k in cols:
            v = item.get(k)
            row.append(", ".join(_num(c, 3) for c in v) if isinstance(v, list) else _num(v, 3))
        rows.append(row)
    return {"header": cols, "rows": rows}


def _figure(files: dict[str, bytes], name: str, alt: str) -> dict[str, Any]:
    src = "data:image/png;base64," + base64.b64encode(files[name]).decode("ascii") if name in files else None
    return {"name": name, "stem": name.rsplit(".", 1)[0], "src": src, "alt": alt}


def _stories(result: Result, files: dict[str, bytes], doc: dict[str, Any]) -> list[dict[str, Any]]:
    rooms = doc.get("rooms") or []
    openings = doc.get("openings") or []
    out = []
    for sp in result.stories:
        s = sp.story
        i = s.index
        plans = []
        for kind, title in (("pen-and-ink", "Pen-and-ink plan"), ("drafting", "Drafting plan")):
            name = f"{kind}-{i}.svg"
            svg = inline_svg(files[name], f"{kind}-{i}", f"{title}, story {i}") if name in files else None
            plans.append({"kind": kind, "title": title, "name": name, "svg": svg})
        envelope = [f for f in (doc.get("envelope") or {}).get("facades", []) if f.get("story") == i and f.get("walls")]
        story_rooms = [r for r in rooms if r.get("story", 0) == i]
        story_openings = [op for op in openings if op.get("story", 0) == i]
        out.append(
            {
                "index": i,
                "head": f"Story {i}: floor {s.floor:.2f} m, ceiling {s.ceiling:.2f} m{'' if s.ceiling_found else ' (not found)'}",
                "plans": plans,
                "rooms": [[r.get("label", ""), _num(r.get("area"), 2), _num(r.get("width"), 2), _num(r.get("depth"), 2)] for r in story_rooms],
                "rooms_total": f"{sum(float(r.get('area') or 0.0) for r in story_rooms):,.2f}",
                "openings": _generic_table(story_openings) if story_openings else None,
                "envelope": [
                    [f["orientation"], f["walls"], _num(f["wall_area"], 2), f["windows"], _num(f["window_area"], 2), f["doors"]]
                    + [_num(f["door_area"], 2), _num(f["wwr"], 3)]
                    for f in envelope
                ],
            }
        )
    return out


def _timings(result: Result) -> tuple[list[str], list[tuple[str, str | None, str | None, str]]]:
    faces = result.input.faces
    rows = []
    for stage in (*STAGES, "total"):
        t = result.timings.get(stage)
        scaled = t * PAPER_FACES / faces if (t is not None and faces) else None
        paper = PAPER_TIMINGS_S.get(stage)
        rows.append(
            (stage, f"{t:.3f}" if t is not None else None, f"{scaled:.3f}" if scaled is not None else None, f"{paper:.2f}" if paper is not None else "—")
        )
    header = ["stage", f"meshplan (s, {faces:,} faces)", f"meshplan scaled to {PAPER_FACES:,} faces (s)", f"paper, B2 ({PAPER_FACES:,} faces) (s)"]
    return header, rows


def _story_rows(result: Result) -> list[list[Any]]:
    return [
        [
            sp.story.index,
            f"{sp.story.floor:.3f}",
            f"{sp.story.ceiling:.3f}" + ("" if sp.story.ceiling_found else " (not found)"),
            f"{sp.story.height:.3f}",
            int(np.count_nonzero(result.walls.story == sp.story.index)),
            len(sp.annotations),
        ]
        for sp in result.stories
    ]


def _input_rows(result: Result, doc: dict[str, Any]) -> list[list[Any]]:
    rows = [[k.replace("_", " "), _num(v, 6) if not isinstance(v, str) else v] for k, v in doc["input"].items()]
    rows.insert(3, ["metres per unit", _num(result.input.scale_to_m, 6)])
    return rows


#: Colour of the energy model's layers in the 3D view (its exterior surfaces; interior ones
#: lighter): the surfaces of model.gbxml, shown without their roofs and ceilings like the scan.
ENERGY_EXTERIOR_HEX = "#d9822b"
ENERGY_INTERIOR_HEX = "#8fb8de"


def _energy_layers(result: Result) -> tuple[ViewMesh, ...]:
    """The energy model's walls and floors (model.gbxml's surfaces, derived from the rooms) as
    layers of the 3D view, one per story and kind (exterior, interior), hidden at first."""
    import shapely

    from ..geometry import Mesh
    from .gbxml import energy_model

    model = energy_model(result)
    groups: dict[tuple[int, bool], tuple[list[np.ndarray], list[np.ndarray]]] = {}
    for s in model.surfaces:
        if s.kind in ("Roof", "Ceiling"):
            continue
        verts, faces = groups.setdefault((s.story, s.exposed), ([], []))
        base = sum(len(v) for v in verts)
        p = s.polygon
        if s.is_wall or len(p) == 3:
            tris = np.array([[0, k, k + 1] for k in range(1, len(p) - 1)])
            pts = p
        else:  # a floor may be concave: triangulated within its outline
            tri = shapely.constrained_delaunay_triangles(shapely.Polygon(p[:, :2]))
            corners = [np.asarray(t.exterior.coords)[:3] for t in shapely.get_parts(tri)]
            pts = np.array([[*c, p[0, 2]] for t in corners for c in t]) if corners else np.zeros((0, 3))
            tris = np.arange(len(pts)).reshape(-1, 3)
        verts.append(pts[:, [0, 2, 1]] * np.array([1.0, 1.0, -1.0]))  # gbXML (x, y, z) -> plan (x, z, -y)
        faces.append(tris + base)
    layers = []
    for (story, exposed), (verts, faces) in sorted(groups.items()):
        if not verts:
            continue
        mesh = Mesh(np.concatenate(verts), np.concatenate(faces))
        name = f"story {story}: energy model, {'exterior' if exposed else 'interior and ground'} surfaces"
        layers.append(ViewMesh(name, "energy-exterior" if exposed else "energy-interior", story, mesh, mesh.n_faces))
    return tuple(layers)


def _with_energy_colors(data: dict[str, Any], view: ViewMeshes) -> dict[str, Any]:
    """The page's data with the energy layers' colours, and the face counts of the scan's own
    layers (``view``), which the energy layers are not part of."""
    data["faces_shown"], data["faces_total"] = view.faces_shown, view.faces_total
    for m in data.get("meshes", []):
        if m.get("role") == "energy-exterior":
            m["color"] = ENERGY_EXTERIOR_HEX
        elif m.get("role") == "energy-interior":
            m["color"] = ENERGY_INTERIOR_HEX
    return data


def _asset(name: str) -> str:
    return resources.files("meshplan").joinpath(f"export/assets/{name}").read_text(encoding="utf-8")


#: plotly.js's 3D-only build (npm ``plotly.js-gl3d-dist-min``, MIT licence beside it in the
#: assets), of the plotly.js version the plotly package bundles: the page draws ``mesh3d`` and
#: ``scatter3d`` traces only, which it holds, in 1.75 MB where the full bundle takes 4.8 MB.
PLOTLY_BUNDLE = "plotly-gl3d.min.js"
PLOTLY_JS_VERSION = "4.1.1"


def _plotly_bundle() -> str:
    """The plotly.js bundle the page inlines, headed by its version (the 3D build's own
    header names its build, not the version alone)."""
    return f"/* plotly.js v{PLOTLY_JS_VERSION}, gl3d build ({PLOTLY_BUNDLE}) */\n" + _asset(PLOTLY_BUNDLE)


def _script(js: str) -> Markup:
    # a literal "</script" would end the element early
    return Markup(js.replace("</script", "<\\/script"))


def _json_script(obj: Any) -> Markup:
    # "<" escaped so that no string in the data can close the script element
    return Markup(json.dumps(obj, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c"))


def report_page(result: Result, *, max_faces: int = MAX_FACES) -> dict[str, Any]:
    """What the page shows that the other files do not hold: the 3D view's data, the tables,
    the bundled scripts (the report's costly part, which :func:`meshplan.export.render_files`
    builds while the drawing workers draw). ``report_html(result, files, page=...)`` fills the
    page from it."""
    doc = plan_document(result)
    view = view_meshes(result, max_faces)
    # the energy model's layers are drawn too, but are no faces of the scan (the note counts those)
    shown = ViewMeshes(view.layers + _energy_layers(result), view.max_faces, view.cell_m)
    if view.cell_m is not None:
        faces_note = (
            f"Showing {view.faces_shown:,} of {view.faces_total:,} faces: the stories without their ceilings "
            f"({view.faces_total:,} faces; the scan {result.input.faces:,}) are simplified on a grid of "
            f"{100 * view.cell_m:.1f} cm cells to keep the page responsive (every vertex moved to the mean of its "
            f"cell: the surface keeps no hole it did not have, corners are cut by up to a cell). Picked points "
            f"lie on the surface shown: on flat walls and floors away from their edges, on the scanned surface; "
            f"elsewhere within a cell of it."
        )
    elif view.decimated:  # a point cloud's splats
        faces_note = (
            f"Showing {view.faces_shown:,} of {view.faces_total:,} splats: a fixed subsample keeps the page "
            f"responsive (the stories without their ceilings have {view.faces_total:,}; the cloud's points "
            f"{result.input.points:,}). Picked points lie on a splat shown."
        )
    else:
        faces_note = (
            f"Showing {view.faces_shown:,} of {view.faces_total:,} faces: every face of the stories without "
            f"their ceilings (the scan has {result.input.faces:,})."
        )
    rooms = doc.get("rooms") or []
    indices = {sp.story.index for sp in result.stories}
    timings_header, timings = _timings(result)
    context = dict(
        scan=result.input.path.replace("\\", "/").rsplit("/", 1)[-1],
        summary=(
            f"{result.input.faces:,} faces, {len(result.stories)} "
            f"{'story' if len(result.stories) == 1 else 'stories'}, {len(result.walls)} flat walls, "
            f"{len(result.annotations)} annotations"
        ),
        version=__version__,
        warnings=list(result.warnings),
        faces_note=faces_note,
        story_indices=[sp.story.index for sp in result.stories],
        kinds=list(ANNOTATION_KINDS),
        units=result.input.units,
        north_deg=f"{result.options.export.north_deg:g}",
        other_rooms=_generic_table(rooms) if rooms and not any(r.get("story", 0) in indices for r in rooms) else None,
        story_rows=_story_rows(result),
        timings_header=timings_header,
        timings=timings,
        input_rows=_input_rows(result, doc),
        parameter_rows=[
            [group, name, json.dumps(value, sort_keys=True)] for group, params in result.options.to_dict().items() for name, value in params.items()
        ],
        css=Markup(_asset("report.css")),
        data=_json_script(_with_energy_colors(page_data(result, shown), view)),
        plotly=_script(_plotly_bundle()),
        script=_script(_asset("report.js")),
    )
    # the template loaded and compiled now (0.03 s in a fresh process: jinja2, the file), while
    # the workers draw, rather than when the last drawing is in
    _environment().get_template("report.html.j2")
    return {"doc": doc, "context": context}


def report_html(result: Result, files: dict[str, bytes], *, max_faces: int = MAX_FACES, page: dict[str, Any] | None = None) -> str:
    """The self-contained report.html of a result.

    Parameters
    ----------
    result
        What :func:`meshplan.run` found.
    files
        The other output files (``name -> bytes``) as :func:`meshplan.export.render_files`
        makes them; the plans (``pen-and-ink-{i}.svg``, ``drafting-{i}.svg``) and figures
        (``levels.png``, ``normals.png``) are taken from there.
    max_faces
        Most faces the 3D view shows (see :data:`~meshplan.export.view3d.MAX_FACES`).
    page
        :func:`report_page` of this result (with this ``max_faces``), when already made.

    Returns
    -------
    str
        The page; it loads nothing from anywhere. Only the timing values change from one run
        of the same scan to the next.
    """
    if page is None:
        page = report_page(result, max_faces=max_faces)
    return _environment().get_template("report.html.j2").render(
        **page["context"],
        stories=_stories(result, files, page["doc"]),
        levels=_figure(files, "levels.png", "altitude histogram"),
        normals=_figure(files, "normals.png", "normals heat map"),
    )
