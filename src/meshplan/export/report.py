"""report.html: one self-contained page with everything a run made, and an annotation editor.

The page works offline and makes no network request: plotly's bundle, the style sheet and the
script are inlined, the plans are inline SVG and the diagnostic figures ``data:`` URIs. It shows

* the oriented 3D model of each story without its ceiling, the flat walls and the annotations,
  each a layer (plotly legend), rotatable and zoomable; large scans are shown as a
  deterministic subsample of whole faces (:func:`view_meshes`), and the page says so;
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
random ids; the face subsample uses a fixed seed).
"""

from __future__ import annotations

import base64
import html
import json
import math
import re
from dataclasses import dataclass
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..geometry import ANNOTATION_KINDS, Mesh, transform_directions, transform_points
from ..orient import without_ceiling
from .glb import KIND_RGBA, MESH_RGBA, WALL_RGBA
from .planjson import plan_document

if TYPE_CHECKING:  # pragma: no cover
    from ..pipeline import Result

__all__ = ["MAX_FACES", "ViewMesh", "ViewMeshes", "report_html", "subsample_faces", "view_meshes"]

#: Most faces the 3D view shows. Measured in Chromium: plotly builds a 120k-face scene in about
#: 1 s and keeps rotating it smoothly, and the page stays well under 15 MB (plotly's bundle is
#: 4.8 MB of it); past this the scan is shown as a subsample of its faces.
MAX_FACES = 120_000

#: Seed of the face subsample (fixed, so that the page is the same for the same result).
SUBSAMPLE_SEED = 0

#: Length of the probe drawn from each annotation along its direction, metres.
PROBE_M = 0.35

#: Label prefix suggested for a new annotation of each kind.
KIND_PREFIX = {"sensor": "S", "thermostat": "T", "window": "W", "door": "D", "other": "O"}

_WALL_VIEW_RGB = WALL_RGBA[:3]


@dataclass(frozen=True, eq=False)
class ViewMesh:
    """One mesh layer of the 3D view.

    Attributes
    ----------
    name
        Legend entry.
    role
        ``"scan"`` (a story without its ceiling) or ``"walls"`` (its flat walls).
    story
        Story index.
    mesh
        The faces shown (plan frame); a subset of whole faces of the scan, never merged ones.
    faces_total
        Faces of the layer before the subsample.
    """

    name: str
    role: str
    story: int
    mesh: Mesh
    faces_total: int

    @property
    def faces_shown(self) -> int:
        return self.mesh.n_faces


@dataclass(frozen=True, eq=False)
class ViewMeshes:
    """The layers of the 3D view and how much of the scan they show."""

    layers: tuple[ViewMesh, ...]
    max_faces: int

    @property
    def faces_shown(self) -> int:
        return sum(layer.faces_shown for layer in self.layers)

    @property
    def faces_total(self) -> int:
        return sum(layer.faces_total for layer in self.layers)

    @property
    def fraction(self) -> float:
        """Fraction of the scan faces shown (1 when nothing was left out)."""
        scan = [layer for layer in self.layers if layer.role == "scan"]
        total = sum(layer.faces_total for layer in scan)
        return sum(layer.faces_shown for layer in scan) / total if total else 1.0

    @property
    def decimated(self) -> bool:
        return self.faces_shown < self.faces_total


def subsample_faces(areas: np.ndarray, m: int, seed: int = SUBSAMPLE_SEED) -> np.ndarray:
    """``m`` of the faces with these ``areas``, as sorted indices: a random choice with a fixed
    seed, each face weighted by its area.

    Random rather than strided: scans list faces surface by surface in grid order, so a stride
    leaves regular stripes (moiré) where a random choice leaves an even, fine-grained dither.
    Weighted by area (Efraimidis and Spirakis' exponential keys, vectorized) so that the faces
    kept cover more of the surface: on a 300k-face scan showing 48 % of the faces covers 59 %
    of the area instead of 48 %.
    """
    n = len(areas)
    if m >= n:
        return np.arange(n)
    if m <= 0:
        return np.zeros(0, dtype=np.int64)
    rng = np.random.default_rng(seed)
    with np.errstate(divide="ignore"):
        keys = -np.log(rng.random(n)) / np.asarray(areas, dtype=np.float64)
    return np.sort(np.argpartition(keys, m - 1)[:m])


def view_meshes(result: Result, max_faces: int = MAX_FACES) -> ViewMeshes:
    """The 3D view's layers: each story without its ceiling and its flat walls.

    When the stories hold more than ``max_faces`` faces in all (flat walls included), the same
    fraction of every story's faces is kept (:func:`subsample_faces`), so that the page stays
    responsive; the flat walls (two faces a wall) are always whole.
    """
    o = result.orientation
    mesh = result.mesh
    heights = mesh.face_centroids[:, 1]
    tol = result.options.orient.slab_tolerance_m
    scan_faces = []
    walls = []
    for sp in result.stories:
        i = sp.story.index
        keep = (o.face_story == i) & without_ceiling(heights, mesh.face_normals[:, 1], sp.story, tol)
        scan_faces.append(np.flatnonzero(keep))
        walls.append(result.walls.mesh(i))
    n_scan = sum(len(f) for f in scan_faces)
    budget = max(max_faces - sum(w.n_faces for w in walls), 0)
    frac = 1.0 if n_scan <= budget else budget / n_scan
    layers = []
    for sp, faces, wall_mesh in zip(result.stories, scan_faces, walls):
        i = sp.story.index
        pick = faces[subsample_faces(mesh.face_areas[faces], int(math.floor(frac * len(faces))), SUBSAMPLE_SEED + i)]
        layers.append(ViewMesh(f"story {i}: scan", "scan", i, mesh.submesh(pick), len(faces)))
        layers.append(ViewMesh(f"story {i}: flat walls", "walls", i, wall_mesh, wall_mesh.n_faces))
    return ViewMeshes(tuple(layers), max_faces)


# --------------------------------------------------------------------------------------------
# Pieces of the page


def _b64(a: np.ndarray, dtype: str) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _hex(rgba) -> str:
    return "#{:02x}{:02x}{:02x}".format(*rgba[:3])


def _finite_or_none(a: np.ndarray, nd: int = 9) -> list[float] | None:
    a = np.asarray(a, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        return None
    return (np.round(a, nd) + 0.0).tolist()


def _layer_data(layer: ViewMesh, slack: float) -> dict[str, Any]:
    """A layer for the page: vertices as x, y and z blocks of float32 (plotly wants them apart)
    and faces as i, j and k blocks of uint32, each base64."""
    m = layer.mesh
    return {
        "name": layer.name,
        "role": layer.role,
        "story": layer.story,
        "color": _hex(MESH_RGBA if layer.role == "scan" else _WALL_VIEW_RGB),
        "visible": layer.role == "scan",
        "n_vertices": m.n_vertices,
        "n_faces": m.n_faces,
        "positions": _b64(m.vertices.T, "<f4"),
        "faces": _b64(m.faces.T, "<u4"),
        # How far (in barycentric units) a click may miss a shown face and still take its
        # plane: a subsample leaves gaps between the faces it keeps.
        "slack": slack if layer.role == "scan" else 0.0,
    }


def _annotation_data(result: Result) -> list[dict[str, Any]]:
    """The scan's annotations in the plan frame (to draw) and in the file's coordinates (to
    export unchanged)."""
    ann = result.annotations
    if not len(ann):
        return []
    inv = np.linalg.inv(result.transform)
    scale = float(result.input.scale_to_m)
    pos_in = transform_points(inv, ann.positions) / scale
    dir_in = transform_directions(inv, ann.directions)
    story = result.annotation_story
    return [
        {
            "label": label,
            "kind": kind,
            "story": int(story[i]) if i < len(story) else None,
            "position": _finite_or_none(ann.positions[i]),
            "direction": _finite_or_none(ann.directions[i]),
            "input_position": _finite_or_none(pos_in[i]),
            "input_direction": _finite_or_none(dir_in[i]),
        }
        for i, (label, kind) in enumerate(zip(ann.labels, ann.kinds))
    ]


def _page_data(result: Result, view: ViewMeshes) -> dict[str, Any]:
    slack = 0.0 if not view.decimated else min(1.0, 1.2 * (1.0 / math.sqrt(max(view.fraction, 1e-6)) - 1.0))
    return {
        "meshplan_version": __version__,
        "meshes": [_layer_data(layer, slack) for layer in view.layers],
        "faces_shown": view.faces_shown,
        "faces_total": view.faces_total,
        "annotations": _annotation_data(result),
        "kinds": list(ANNOTATION_KINDS),
        "kind_colors": {k: _hex(KIND_RGBA.get(k, KIND_RGBA["other"])) for k in ANNOTATION_KINDS},
        "kind_prefix": KIND_PREFIX,
        "to_input": np.linalg.inv(result.transform).tolist(),
        "scale_to_m": float(result.input.scale_to_m),
        "units": result.input.units,
        "stories": [
            {
                "index": s.index,
                "floor": s.floor,
                "ceiling": s.ceiling,
                "bottom": s.bottom if math.isfinite(s.bottom) else None,
                "top": s.top if math.isfinite(s.top) else None,
            }
            for s in result.orientation.stories
        ],
        "probe_m": PROBE_M,
    }


def _json_script(obj: Any) -> str:
    # "<" escaped so that no string in the data can close the script element
    return json.dumps(obj, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")


_ID = re.compile(r'\bid="([^"]+)"')
_REF = re.compile(r'(href="#|url\(#)([^")]+)')


def inline_svg(data: bytes, prefix: str, title: str) -> str:
    """An SVG file as an element to put in the page.

    The XML prologue and metadata go; every id gets ``prefix`` (matplotlib numbers its ids
    the same way in every figure, so two plans in one page would otherwise share them, and a
    reference could draw the other plan's marker), and the drawing scales to its box.
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
    return head + text[head_end:]


def _png(files: dict[str, bytes], name: str, alt: str) -> str:
    if name not in files:
        return f'<p class="missing">{html.escape(name)} was not made.</p>'
    src = "data:image/png;base64," + base64.b64encode(files[name]).decode("ascii")
    return f'<img class="figure" id="img-{html.escape(name.rsplit(".", 1)[0])}" src="{src}" alt="{html.escape(alt)}">'


def _table(table_id: str, header: list[str], rows: list[list[Any]], cls: str = "") -> str:
    h = "".join(f"<th>{html.escape(str(c))}</th>" for c in header)
    body = "".join(
        "<tr>" + "".join(f"<td>{c if isinstance(c, _Raw) else html.escape(str(c))}</td>" for c in row) + "</tr>"
        for row in rows
    )
    return f'<table id="{table_id}" class="{cls}"><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>'


class _Raw(str):
    """Table cell content that is already HTML."""


def _num(v: Any, nd: int = 3) -> str:
    if isinstance(v, bool) or v is None:
        return "—" if v is None else str(v).lower()
    if isinstance(v, (int, np.integer)):
        return f"{int(v):,}"
    if isinstance(v, (float, np.floating)):
        return f"{float(v):,.{nd}f}"
    return str(v)


def _plans_section(result: Result, files: dict[str, bytes], doc: dict[str, Any]) -> str:
    rooms = doc.get("rooms") or []
    openings = doc.get("openings") or []
    out = []
    for sp in result.stories:
        s = sp.story
        i = s.index
        figs = []
        for kind, title in (("pen-and-ink", "Pen-and-ink plan"), ("drafting", "Drafting plan")):
            name = f"{kind}-{i}.svg"
            body = (
                inline_svg(files[name], f"{kind}-{i}", f"{title}, story {i}")
                if name in files
                else f'<p class="missing">{html.escape(name)} was not made.</p>'
            )
            figs.append(f'<figure class="plan" id="plan-{kind}-{i}">{body}<figcaption>{title}, story {i}</figcaption></figure>')
        head = f"Story {i}: floor {s.floor:.2f} m, ceiling {s.ceiling:.2f} m{'' if s.ceiling_found else ' (not found)'}"
        block = [f'<section class="story" id="story-{i}"><h3>{html.escape(head)}</h3><div class="plans">{"".join(figs)}</div>']
        story_rooms = [r for r in rooms if r.get("story", 0) == i]
        if story_rooms:
            rows = [
                [r.get("label", ""), _num(r.get("area"), 2), _num(r.get("width"), 2), _num(r.get("depth"), 2)]
                for r in story_rooms
            ]
            total = sum(float(r.get("area") or 0.0) for r in story_rooms)
            rows.append([_Raw("<b>total</b>"), _Raw(f"<b>{total:,.2f}</b>"), "", ""])
            block.append("<h4>Rooms</h4>" + _table(f"rooms-{i}", ["room", "area (m²)", "width (m)", "depth (m)"], rows, "rooms"))
        story_openings = [op for op in openings if op.get("story", 0) == i]
        if story_openings:
            block.append("<h4>Openings</h4>" + _generic_table(f"openings-{i}", story_openings))
        block.append("</section>")
        out.append("".join(block))
    if rooms and not any(r.get("story", 0) in {sp.story.index for sp in result.stories} for r in rooms):
        out.append("<h4>Rooms</h4>" + _generic_table("rooms", rooms))
    return "".join(out)


def _generic_table(table_id: str, items: list[dict[str, Any]]) -> str:
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
    return _table(table_id, cols, rows)


def _timings_section(result: Result) -> str:
    from ..pipeline import PAPER_FACES, PAPER_TIMINGS_S, STAGES

    faces = result.input.faces
    rows = []
    for stage in (*STAGES, "total"):
        t = result.timings.get(stage)
        scaled = t * PAPER_FACES / faces if (t is not None and faces) else None
        paper = PAPER_TIMINGS_S.get(stage)
        rows.append(
            [
                stage,
                _Raw(f'<span class="timing">{t:.3f}</span>') if t is not None else "—",
                _Raw(f'<span class="timing">{scaled:.3f}</span>') if scaled is not None else "—",
                f"{paper:.2f}" if paper is not None else "—",
            ]
        )
    return _table(
        "timings",
        ["stage", f"meshplan (s, {faces:,} faces)", f"meshplan scaled to {PAPER_FACES:,} faces (s)", f"paper, B2 ({PAPER_FACES:,} faces) (s)"],
        rows,
    )


def _parameters_section(result: Result) -> str:
    rows = []
    for group, params in result.options.to_dict().items():
        for name, value in params.items():
            rows.append([group, name, json.dumps(value, sort_keys=True)])
    return _table("parameters", ["stage", "parameter", "value"], rows)


def _input_section(result: Result, doc: dict[str, Any]) -> str:
    rows = [[k.replace("_", " "), _num(v, 6) if not isinstance(v, str) else v] for k, v in doc["input"].items()]
    rows.insert(3, ["metres per unit", _num(result.input.scale_to_m, 6)])
    return _table("input", ["", "value"], rows)


def _stories_section(result: Result) -> str:
    rows = []
    for sp in result.stories:
        s = sp.story
        rows.append(
            [
                s.index,
                f"{s.floor:.3f}",
                f"{s.ceiling:.3f}" + ("" if s.ceiling_found else " (not found)"),
                f"{s.height:.3f}",
                int(np.count_nonzero(result.walls.story == s.index)),
                len(sp.annotations),
            ]
        )
    return _table("stories", ["story", "floor (m)", "ceiling (m)", "height (m)", "flat walls", "annotations"], rows)


def _asset(name: str) -> str:
    return resources.files("meshplan").joinpath(f"export/assets/{name}").read_text(encoding="utf-8")


def _script(js: str) -> str:
    # a literal "</script" would end the element early
    return "<script>" + js.replace("</script", "<\\/script") + "</script>"


# --------------------------------------------------------------------------------------------


def report_html(result: Result, files: dict[str, bytes], *, max_faces: int = MAX_FACES) -> str:
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
        Most faces the 3D view shows (see :data:`MAX_FACES`).

    Returns
    -------
    str
        The page; it loads nothing from anywhere. Only the timing values change from one run
        of the same scan to the next.
    """
    import plotly.offline

    doc = plan_document(result)
    view = view_meshes(result, max_faces)
    data = _page_data(result, view)
    scan = result.input.path.replace("\\", "/").rsplit("/", 1)[-1]
    e = html.escape

    if view.decimated:
        faces_note = (
            f"Showing {view.faces_shown:,} of {view.faces_total:,} faces: a fixed subsample of whole faces keeps "
            f"the page responsive (the stories without their ceilings have {view.faces_total:,} faces; the scan "
            f"{result.input.faces:,}). Picked points still lie on the scanned surface."
        )
    else:
        faces_note = (
            f"Showing {view.faces_shown:,} of {view.faces_total:,} faces: every face of the stories without "
            f"their ceilings (the scan has {result.input.faces:,})."
        )
    warnings = "".join(f"<li>{e(w)}</li>" for w in result.warnings)
    warn_block = f'<section id="warnings" class="warnings"><h2>Warnings</h2><ul>{warnings}</ul></section>' if warnings else ""
    kinds = "".join(f'<option value="{k}">{k}</option>' for k in ANNOTATION_KINDS)
    story_buttons = "".join(
        f'<button type="button" class="story-btn" data-story="{sp.story.index}">story {sp.story.index}</button>'
        for sp in result.stories
    )
    summary = (
        f"{result.input.faces:,} faces, {len(result.stories)} "
        f"{'story' if len(result.stories) == 1 else 'stories'}, {len(result.walls)} flat walls, "
        f"{len(result.annotations)} annotations"
    )

    parts = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        '<meta name="viewport" content="width=device-width, initial-scale=1">',
        # belt and braces: the page has nothing to fetch, and says so to the browser
        "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; script-src 'unsafe-inline' 'unsafe-eval'; "
        "style-src 'unsafe-inline'; img-src data: blob:; worker-src blob:\">",
        f"<title>meshplan report: {e(scan)}</title>",
        f"<style>{_asset('report.css')}</style>",
        "</head><body>",
        f'<header><h1>meshplan report: <span id="scan-name">{e(scan)}</span></h1>',
        f'<p class="summary">{e(summary)}. meshplan {e(__version__)}. Plan frame: metres, +y up; plans seen '
        "from above with x to the right and z down the page.</p></header>",
        warn_block,
        '<section id="model"><h2>3D model</h2>',
        f'<p id="faces-note" class="note">{e(faces_note)}</p>',
        '<div class="toolbar"><span>View:</span>'
        '<button type="button" id="view-3d">3D</button><button type="button" id="view-top">from above</button>'
        f'<span>Stories:</span><button type="button" class="story-btn" data-story="all">all</button>{story_buttons}'
        '<span class="hint">Drag to rotate, scroll to zoom; click the legend to switch layers.</span></div>',
        '<div class="model-row"><div id="model3d" class="model3d"></div>',
        '<aside id="annotate" class="annotate"><h3>Annotations</h3>',
        '<p class="hint">Click a point of the model (without dragging) to pick it; the probe is the '
        "normal of the face clicked, towards you. Then choose the kind and a label, and add it.</p>",
        '<div id="pending" class="pending">No point picked.</div>',
        f'<div class="form"><label>Kind <select id="ann-kind">{kinds}</select></label>',
        '<label>Label <input id="ann-label" type="text" autocomplete="off" spellcheck="false"></label>',
        '<button type="button" id="ann-add" disabled>Add</button>'
        '<button type="button" id="ann-cancel" disabled>Cancel</button></div>',
        '<div id="ann-error" class="error" role="alert"></div>',
        '<table id="ann-table"><thead><tr><th>label</th><th>kind</th><th>story</th><th>position (m)</th><th></th></tr></thead><tbody></tbody></table>',
        f'<button type="button" id="ann-export" class="primary">Export annotations.json</button>'
        f'<p class="hint">Saved in the scan\'s own coordinates and units ({e(result.input.units)}), for '
        "<code>meshplan run --annotations</code>.</p>",
        "</aside></div></section>",
        '<section id="plans"><h2>Plans</h2>',
        _plans_section(result, files, doc),
        "</section>",
        '<section id="diagnostics"><h2>Levels and normals</h2><div class="figures">',
        f'<figure>{_png(files, "levels.png", "altitude histogram")}<figcaption>Altitude histogram: floor and ceiling levels</figcaption></figure>',
        f'<figure>{_png(files, "normals.png", "normals heat map")}<figcaption>Normals heat map</figcaption></figure>',
        "</div></section>",
        '<section id="run"><h2>Stories</h2>',
        _stories_section(result),
        "<h2>Timings</h2>",
        _timings_section(result),
        '<p class="note">The report is made during the write stage: the write and total times are in plan.json. '
        "Scaled times assume time grows with the number of faces.</p>",
        "<h2>Input</h2>",
        _input_section(result, doc),
        "<h2>Parameters</h2>",
        _parameters_section(result),
        "</section>",
        f'<script type="application/json" id="meshplan-data">{_json_script(data)}</script>',
        _script("window.PlotlyConfig = {MathJaxConfig: 'local'};"),
        _script(plotly.offline.get_plotlyjs()),
        _script(_asset("report.js")),
        "</body></html>",
    ]
    return "\n".join(parts) + "\n"
