"""report.html: self-contained, deterministic, and usable in a real headless Chromium (the 3D
view, the plans, and placing an annotation by clicking the model, exported and read back)."""

from __future__ import annotations

import base64
import html
import json
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

import meshplan
from meshplan.export.glb import submesh
from meshplan.export.report import report_html, view_meshes
from meshplan.export.synth import write_synthetic
from meshplan.synthetic import SynthParams, generate
from test_view3d import decode_layer, position_bound

pytestmark = pytest.mark.slow  # whole runs of meshplan: not part of the unit layer (-m "not slow")

CHROMIUM = Path("/usr/bin/chromium")
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
#: Set to a directory to keep the screenshots the browser test takes.
SHOTS = os.environ.get("MESHPLAN_REPORT_SHOTS")


@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """A small synthetic room (no furniture, so that its floor is in view), run once."""
    tmp = tmp_path_factory.mktemp("report")
    scan = write_synthetic(generate(SynthParams(preset="room", seed=5, furniture=False)), tmp / "scan")
    result = meshplan.run(scan, annotations=tmp / "scan" / "annotations.json", output=tmp / "out")
    return tmp, scan, result


_DATA = re.compile(r'<script type="application/json" id="meshplan-data">(.*?)</script>', re.S)


def _page_data(page: str) -> dict:
    """The page's ``meshplan-data`` JSON."""
    return json.loads(_DATA.search(page).group(1))


def _with_page_data(page: str, data: dict) -> str:
    """The page with other data (escaped as report.py escapes them)."""
    text = json.dumps(data, separators=(",", ":")).replace("<", "\\u003c")
    return _DATA.sub(lambda _: f'<script type="application/json" id="meshplan-data">{text}</script>', page, count=1)


def _files(out: Path) -> dict[str, bytes]:
    return {p.name: p.read_bytes() for p in out.iterdir() if p.suffix in (".svg", ".png")}


def _floor_target(result, layer_mesh, depth: float = 0.5) -> np.ndarray:
    """The centroid of the shown floor face nearest the middle of the floor's width, ``depth``
    of the way down the plan (plan frame). The default 3D camera looks from the bottom of the
    plan (+z) at 45 degrees, so the near wall hides the floor behind it: a target at
    ``depth=0.25`` is in view."""
    up = layer_mesh.face_normals[:, 1] > 0.95
    low = np.abs(layer_mesh.face_centroids[:, 1] - result.stories[0].story.floor) < 0.05
    c = layer_mesh.face_centroids[up & low]
    lo, hi = c.min(axis=0), c.max(axis=0)
    mid = 0.5 * (lo + hi)
    mid[2] = lo[2] + depth * (hi[2] - lo[2])
    return c[np.argmin(np.linalg.norm((c - mid)[:, [0, 2]], axis=1))]


def _distance_to_surface(mesh, p: np.ndarray, radius: float = 0.3) -> float:
    """Distance from ``p`` to the faces of ``mesh`` it projects into (faces near it only)."""
    near = np.flatnonzero(np.linalg.norm(mesh.face_centroids - p, axis=1) < radius)
    t = mesh.triangles[near]
    n = mesh.face_normals[near]
    d = np.einsum("ij,ij->i", p - t[:, 0], n)
    q = p - d[:, None] * n  # p projected on each face's plane
    e1, e2, w = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0], q - t[:, 0]
    d11, d12, d22 = (e1 * e1).sum(1), (e1 * e2).sum(1), (e2 * e2).sum(1)
    w1, w2 = (w * e1).sum(1), (w * e2).sum(1)
    den = d11 * d22 - d12 * d12
    u, v = (d22 * w1 - d12 * w2) / den, (d11 * w2 - d12 * w1) / den
    inside = (u >= -1e-9) & (v >= -1e-9) & (u + v <= 1 + 1e-9)
    return float(np.min(np.abs(d[inside]))) if inside.any() else np.inf


# --------------------------------------------------------------------------------------------
# Without a browser


def test_report_written_self_contained_and_deterministic(room):
    tmp, _, result = room
    page = (tmp / "out" / "report.html").read_text(encoding="utf-8")
    assert "report.html" in result.files
    # nothing to fetch: every script inline, no external style, image or font, no MathJax
    # (plotly's bundle names URLs for maps it never draws here; the browser test checks that
    # no request is made at all)
    assert not re.search(r"<script[^>]*\ssrc\s*=", page, re.I)
    assert "Plotly" in page and "plotly.js v" in page
    markup = re.sub(r"<script[^>]*>.*?</script>", "", page, flags=re.S)
    assert not re.search(r"""\s(src|href)\s*=\s*["']?(https?:)?//""", markup, re.I)
    assert "<link" not in markup.lower() and "<iframe" not in markup.lower()
    assert not re.search(r"url\(\s*['\"]?(https?:)?//", markup)
    assert "@import" not in page and "@font-face" not in page and "mathjax" not in markup.lower()
    # every story's plans inline, the figures as data URIs, the tables
    for sp in result.stories:
        i = sp.story.index
        for kind in ("pen-and-ink", "drafting"):
            assert re.search(rf'<figure class="plan" id="plan-{kind}-{i}"><svg ', page)
    assert 'id="img-levels" src="data:image/png;base64,' in page
    assert 'id="img-normals" src="data:image/png;base64,' in page
    for table in ("timings", "parameters", "input", "stories"):
        assert f'<table id="{table}"' in page
    assert "24.08" in page and "285,840" in page  # the paper's figures beside ours
    if json.loads((tmp / "out" / "plan.json").read_text()).get("rooms"):
        assert '<table id="rooms-0"' in page
    # the same result gives the same page
    files = _files(tmp / "out")
    assert report_html(result, files) == report_html(result, files)


def test_svg_ids_are_prefixed_per_plan(room):
    tmp, _, result = room
    page = report_html(result, _files(tmp / "out"))
    ids = re.findall(r'\sid="([^"]+)"', page)
    assert len(ids) == len(set(ids)), "two elements share an id"
    for ref in set(re.findall(r'href="#([^"]+)"', page)):
        assert ref in ids


def _open_edges_m(mesh) -> float:
    """Length of the edges of ``mesh`` with one face only, metres (its holes' and rims')."""
    f = mesh.faces
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, first, counts = np.unique(e[:, 0] * mesh.n_vertices + e[:, 1], return_index=True, return_counts=True)
    b = e[first[counts == 1]]
    return float(np.linalg.norm(mesh.vertices[b[:, 0]] - mesh.vertices[b[:, 1]], axis=1).sum())


def test_large_scans_are_simplified_without_holes(room):
    """Past max_faces the stories are simplified (vertex clustering on a voxel grid): no more
    faces than that, no hole the scan had not (open edges: the room's scan, made of pieces
    that meet edge to edge without sharing their vertices, has 231 m of them; simplified, 59 m:
    the pieces are sewn together), the same surface within a cell, and the page says so."""
    from scipy.spatial import cKDTree

    tmp, _, result = room
    view = view_meshes(result, max_faces=5000)
    assert view.decimated and view.cell_m is not None
    assert 0.8 * 5000 <= view.faces_shown <= 5000
    page = report_html(result, _files(tmp / "out"), max_faces=5000)
    assert f"Showing {view.faces_shown:,} of {view.faces_total:,} faces" in page
    assert f"simplified on a grid of {100 * view.cell_m:.1f} cm cells" in page
    tree = cKDTree(result.mesh.vertices)
    for sp in result.stories:
        (layer,) = [v for v in view.layers if v.role == "scan" and v.story == sp.story.index]
        scan = submesh(result.mesh, sp.model_faces)
        assert layer.faces_total == scan.n_faces and layer.faces_shown < scan.n_faces
        assert _open_edges_m(layer.mesh) < 0.5 * _open_edges_m(scan)
        assert abs(layer.mesh.face_areas.sum() / scan.face_areas.sum() - 1.0) < 0.1
        # every vertex the mean of its cell's vertices: within the cell's diagonal of one of them
        d, _ = tree.query(layer.mesh.vertices)
        assert d.max() <= np.sqrt(3.0) * view.cell_m
    # the flat walls are whole; the full view says it shows everything, exactly
    for w in (v for v in view.layers if v.role == "walls"):
        assert w.faces_shown == w.faces_total
    full = view_meshes(result)
    assert not full.decimated and full.cell_m is None
    assert f"Showing {full.faces_shown:,} of {full.faces_total:,} faces" in report_html(result, _files(tmp / "out"))
    for layer, sp in zip([v for v in full.layers if v.role == "scan"], result.stories):
        np.testing.assert_array_equal(layer.mesh.triangles, submesh(result.mesh, sp.model_faces).triangles)


def test_page_meshes_decode_to_the_faces_shown(room):
    """The packed layers of the page (view3d._layer_data) decode, as report.js decodes them, to
    the faces of the view: the same corners (each decoded vertex one vertex of the layer), each
    within the quantization's stated error, in a fraction of the former size."""
    tmp, _, result = room
    data = _page_data((tmp / "out" / "report.html").read_text(encoding="utf-8"))
    by_name = {m["name"]: m for m in data["meshes"]}
    for layer in view_meshes(result).layers:
        m = by_name[layer.name]
        pos, faces = decode_layer(m)
        assert m["n_faces"] == layer.mesh.n_faces and m["face_dtype"] == "uint16"  # under 65536 vertices
        pairs = np.unique(np.stack([faces.ravel(), layer.mesh.faces.ravel()], axis=1), axis=0)
        assert len(pairs) == m["n_vertices"] == len(np.unique(pairs[:, 1])), "a decoded vertex is not one vertex of the layer"
        step = np.array(m["position_step"])
        assert np.all(step <= 12.0 / 65535)  # the room is under 12 m across: under 0.1 mm off
        assert np.all(np.abs(pos[faces] - layer.mesh.triangles) <= position_bound(layer.mesh.triangles, step))
    for m in data["meshes"]:  # the energy model's layers too
        pos, faces = decode_layer(m)
        assert len(faces) == m["n_faces"] and np.all(np.isfinite(pos))
    # float32 coordinates and uint32 indices (base64) took 25 bytes a face shown here; 4 now
    size = sum(len(m["positions"]) + len(m["faces"]) for m in data["meshes"])
    assert size / data["faces_shown"] < 8.0, size / data["faces_shown"]


def test_model_without_ceiling_every_parameter_and_room_areas(room):
    tmp, _, result = room
    page = (tmp / "out" / "report.html").read_text(encoding="utf-8")
    # the 3D view shows each story without its ceiling (but with its floor)
    for sp in result.stories:
        s = sp.story

        def ceiling_faces(mesh, s=s) -> int:
            c, n = mesh.face_centroids, mesh.face_normals
            return int(np.count_nonzero((np.abs(c[:, 1] - s.ceiling) < 0.05) & (n[:, 1] < -0.9)))

        assert ceiling_faces(result.mesh) > 100  # the scan has a ceiling
        (layer,) = [v for v in view_meshes(result).layers if v.role == "scan" and v.story == s.index]
        assert ceiling_faces(layer.mesh) == 0
        assert np.count_nonzero((np.abs(layer.mesh.face_centroids[:, 1] - s.floor) < 0.05) & (layer.mesh.face_normals[:, 1] > 0.9)) > 100
    # every parameter used, with its value
    table = re.search(r'<table id="parameters".*?</table>', page, re.S).group(0)
    for group, params in result.options.to_dict().items():
        for name, value in params.items():
            assert f"<td>{group}</td><td>{name}</td><td>{html.escape(json.dumps(value, sort_keys=True))}</td>" in table, name
    # the rooms of each story with their areas
    for r in json.loads((tmp / "out" / "plan.json").read_text()).get("rooms") or []:
        rooms = re.search(rf'<table id="rooms-{r["story"]}".*?</table>', page, re.S).group(0)
        assert f"<td>{html.escape(r['label'])}</td><td>{r['area']:,.2f}</td>" in rooms


# --------------------------------------------------------------------------------------------
# In Chromium


@pytest.fixture(scope="module")
def browser():
    if not CHROMIUM.exists():
        pytest.skip("headless browser tests need Debian's chromium at /usr/bin/chromium (apt-get install -y chromium)")
    sync_api = pytest.importorskip("playwright.sync_api", reason="the browser tests need the playwright package")
    with sync_api.sync_playwright() as p:
        b = p.chromium.launch(executable_path=str(CHROMIUM), args=CHROMIUM_ARGS)
        yield b
        b.close()


class _Page:
    """A page that records every request and every console error."""

    def __init__(self, browser, url: str, *, init_script: str | None = None, expect_error: bool = False) -> None:
        self.context = browser.new_context(viewport={"width": 1400, "height": 1000}, accept_downloads=True)
        if init_script:
            self.context.add_init_script(init_script)
        self.page = self.context.new_page()
        self.requests: list[str] = []
        self.errors: list[str] = []
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.on("console", lambda m: self.errors.append(m.text) if m.type == "error" else None)
        self.page.on("pageerror", lambda e: self.errors.append(str(e)))
        self.url = url
        self.page.goto(url)
        self.page.wait_for_function("window.meshplanReport && (meshplanReport.ready || meshplanReport.error)", timeout=60_000)
        if not expect_error:
            assert self.page.evaluate("meshplanReport.error") is None

    def settle(self, point) -> dict:
        """Where ``point`` is drawn, once the camera has stopped moving."""
        last = None
        for _ in range(50):
            xy = self.page.evaluate("p => meshplanReport.toScreen(p)", list(map(float, point)))
            if last and xy and abs(xy["x"] - last["x"]) < 0.05 and abs(xy["y"] - last["y"]) < 0.05:
                return xy
            last = xy
            self.page.wait_for_timeout(100)
        raise AssertionError("the camera did not settle")

    def external_requests(self) -> list[str]:
        # blob: is the download the page makes itself, not a network request
        return [u for u in self.requests if u != self.url and not u.startswith("blob:")]

    def close(self) -> None:
        self.context.close()


def _shot(locator, path: Path) -> np.ndarray:
    from PIL import Image

    locator.screenshot(path=str(path))
    if SHOTS:
        shutil.copy(path, Path(SHOTS) / f"report_{path.name}")
    return np.asarray(Image.open(path).convert("RGB")).astype(np.int16)


def _share_unlike(img: np.ndarray, rgb) -> float:
    return float(np.mean(np.abs(img - np.array(rgb, dtype=np.int16)).max(axis=2) > 24))


@pytest.mark.browser
def test_report_in_chromium_click_to_annotate_round_trip(room, browser):
    tmp, scan, result = room
    report = tmp / "out" / "report.html"
    pg = _Page(browser, report.as_uri())
    page = pg.page
    try:
        # the layers and every story's plans are there
        names = page.evaluate("document.getElementById('model3d').data.map(t => t.name)")
        for sp in result.stories:
            i = sp.story.index
            assert f"story {i}: scan" in names and f"story {i}: flat walls" in names
            assert page.locator(f"#plan-pen-and-ink-{i} svg").count() == 1
            assert page.locator(f"#plan-drafting-{i} svg").count() == 1
        for kind in set(result.annotations.kinds):
            assert kind in names

        # the model and the plans are drawn (not blank)
        page.screenshot(path=str(tmp / "page.png"), full_page=True)
        if SHOTS:
            shutil.copy(tmp / "page.png", Path(SHOTS) / "report_test_page.png")
        model = _shot(page.locator("#model3d"), tmp / "model.png")
        assert _share_unlike(model, (0xF4, 0xF5, 0xF7)) > 0.10, "the 3D view is blank"
        plan = _shot(page.locator("#plan-pen-and-ink-0 svg"), tmp / "plan.png")
        assert _share_unlike(plan, (255, 255, 255)) > 0.02, "the pen-and-ink plan is blank"
        drafting = _shot(page.locator("#plan-drafting-0 svg"), tmp / "drafting.png")
        assert _share_unlike(drafting, (255, 255, 255)) > 0.01, "the drafting plan is blank"
        assert page.evaluate("document.getElementById('img-levels').naturalWidth") > 0
        assert page.evaluate("document.getElementById('img-normals').naturalWidth") > 0

        # a layer can be switched on from the legend
        walls = names.index("story 0: flat walls")
        page.locator(".legend .traces", has_text="story 0: flat walls").click()
        page.wait_for_function(f"document.getElementById('model3d').data[{walls}].visible === true")
        page.locator(".legend .traces", has_text="story 0: flat walls").click()
        page.wait_for_function(f"document.getElementById('model3d').data[{walls}].visible === 'legendonly'")

        # click the floor with the mouse, in the default 3D view (far half of the room: in view)
        layer = view_meshes(result).layers[0]
        target = _floor_target(result, layer.mesh, depth=0.25)
        xy = pg.settle(target)
        page.mouse.click(xy["x"], xy["y"])
        page.wait_for_function("meshplanReport.pending !== null")
        picked = np.array(page.evaluate("meshplanReport.pending.position"))
        assert np.linalg.norm(picked - target) < 0.02
        # plotly's own GPU pick at that pixel agrees with our camera (nearest vertex of the face)
        plotly_pick = page.evaluate("meshplanReport.lastPlotlyClick")
        if plotly_pick is not None:
            assert np.linalg.norm(np.array(plotly_pick["position"]) - target) < 0.3

        page.select_option("#ann-kind", "sensor")
        page.fill("#ann-label", "Clicked 1")
        page.click("#ann-add")
        assert page.locator('#ann-table tr[data-label="Clicked 1"]').count() == 1
        with page.expect_download() as dl:
            page.click("#ann-export")
        exported = tmp / "exported.json"
        dl.value.save_as(exported)

        assert pg.errors == [], pg.errors
        assert pg.external_requests() == [], pg.external_requests()
    finally:
        pg.close()

    # the scan's annotations come back unchanged, and the new one is there
    doc = json.loads(exported.read_text())
    original = json.loads((tmp / "scan" / "annotations.json").read_text())["annotations"]
    assert doc["annotations"][: len(original)] == original
    new = doc["annotations"][-1]
    assert (new["label"], new["kind"]) == ("Clicked 1", "sensor")

    # fed back to meshplan, it lands where it was clicked, on the floor, probing up
    again = meshplan.run(scan, annotations=exported)
    np.testing.assert_allclose(again.transform, result.transform, atol=1e-12)
    k = again.annotations.labels.index("Clicked 1")
    position = again.annotations.positions[k]
    assert np.linalg.norm(position - target) < 0.02
    assert _distance_to_surface(result.mesh, position) < 0.01
    assert again.annotations.directions[k] @ [0.0, 1.0, 0.0] > 0.95


@pytest.mark.browser
def test_model_rotates_and_zooms_with_the_mouse(room, browser):
    tmp, _, _ = room
    pg = _Page(browser, (tmp / "out" / "report.html").as_uri())
    page = pg.page
    eye = "(() => { const e = document.getElementById('model3d')._fullLayout.scene._scene.getCamera().eye; return [e.x, e.y, e.z]; })()"
    try:
        box = page.locator("#model3d").bounding_box()
        x, y = box["x"] + box["width"] / 2, box["y"] + box["height"] / 2
        before = np.array(page.evaluate(eye))
        page.mouse.move(x, y)
        page.mouse.down()
        page.mouse.move(x + 180, y + 40, steps=12)
        page.mouse.up()
        page.wait_for_timeout(300)
        turned = np.array(page.evaluate(eye))
        assert np.linalg.norm(turned - before) > 0.1, "dragging did not rotate the model"
        assert abs(np.linalg.norm(turned) - np.linalg.norm(before)) < 0.05 * np.linalg.norm(before)  # a turn, not a zoom
        page.mouse.move(x, y)
        for _ in range(5):
            page.mouse.wheel(0, -200)
            page.wait_for_timeout(50)
        page.wait_for_timeout(300)
        zoomed = np.array(page.evaluate(eye))
        assert np.linalg.norm(zoomed) < 0.9 * np.linalg.norm(turned), "the wheel did not zoom in"
        assert pg.errors == [] and pg.external_requests() == []
    finally:
        pg.close()


@pytest.mark.browser
def test_click_on_simplified_model_stays_on_the_surface(room, browser):
    """A scan simplified to 6,000 faces (a quarter of the room's): seen from above, its floor
    shows no hole (the former subsample of whole faces let the background through a good part
    of it), and a click lands on the surface shown, which on the floor is the scanned floor."""
    tmp, _, result = room
    page_path = tmp / "small.html"
    page_path.write_text(report_html(result, _files(tmp / "out"), max_faces=6000), encoding="utf-8")
    pg = _Page(browser, page_path.as_uri())
    try:
        assert pg.page.evaluate("meshplanReport.data.faces_shown") <= 6000
        # the layers the page decoded are those decoded here from its data, bit for bit
        js = pg.page.evaluate("meshplanReport.meshes.map(m => [m.name, [m.x, m.y, m.z, m.i, m.j, m.k].map(a => Array.from(a))])")
        for (name, arrays), m in zip(js, _page_data(page_path.read_text(encoding="utf-8"))["meshes"]):
            pos, faces = decode_layer(m)
            assert name == m["name"]
            np.testing.assert_array_equal(np.array(arrays[:3], dtype=np.float32).reshape(3, -1).T, pos)
            np.testing.assert_array_equal(np.array(arrays[3:], dtype=np.int64).reshape(3, -1).T, faces)
        pg.page.click("#view-top")
        layer = view_meshes(result, max_faces=6000).layers[0]
        # the middle of the floor, seen from above: floor everywhere, no background
        c, n = layer.mesh.face_centroids, layer.mesh.face_normals
        floor = c[(n[:, 1] > 0.95) & (np.abs(c[:, 1] - result.stories[0].story.floor) < 0.05)]
        lo, hi = floor.min(axis=0), floor.max(axis=0)
        a, b = pg.settle(lo + 0.3 * (hi - lo)), pg.settle(lo + 0.7 * (hi - lo))
        model = _shot(pg.page.locator("#model3d"), tmp / "small-top.png")
        box = pg.page.locator("#model3d").bounding_box()
        x0, x1 = sorted(int(round(p["x"] - box["x"])) for p in (a, b))
        y0, y1 = sorted(int(round(p["y"] - box["y"])) for p in (a, b))
        middle = model[y0:y1, x0:x1]
        assert middle.shape[0] > 50 and middle.shape[1] > 50
        assert 1.0 - _share_unlike(middle, (0xF4, 0xF5, 0xF7)) < 0.002, "the background shows through the floor"
        for target in (_floor_target(result, layer.mesh), _floor_target(result, result.mesh) + [0.31, 0.0, -0.27]):
            xy = pg.settle(target)
            pg.page.mouse.click(xy["x"], xy["y"])
            pg.page.wait_for_function("meshplanReport.pending !== null")
            picked = np.array(pg.page.evaluate("meshplanReport.pending.position"))
            pg.page.click("#ann-cancel")
            assert np.linalg.norm((picked - target)[[0, 2]]) < 0.02
            assert _distance_to_surface(layer.mesh, picked) < 1e-3  # on a face shown
            assert _distance_to_surface(result.mesh, picked) < 0.01
        assert pg.errors == [] and pg.external_requests() == []
    finally:
        pg.close()


@pytest.mark.browser
def test_model_that_cannot_be_decoded_says_so(room, browser):
    """The 3D view is set up asynchronously (the browser inflates the meshes): a failure on the
    way is still reported (meshplanReport.error, the console, a message in place of the plot),
    and the annotation panel works without it."""
    tmp, _, result = room
    page = (tmp / "out" / "report.html").read_text(encoding="utf-8")
    data = _page_data(page)
    data["meshes"][0]["faces"] = base64.b64encode(b"not deflate data").decode("ascii")
    broken = tmp / "broken.html"
    broken.write_text(_with_page_data(page, data), encoding="utf-8")
    cases = [
        (broken.as_uri(), None, "could not be drawn"),
        ((tmp / "out" / "report.html").as_uri(), "delete window.DecompressionStream;", "DecompressionStream"),
    ]
    for url, init_script, message in cases:
        pg = _Page(browser, url, init_script=init_script, expect_error=True)
        try:
            assert not pg.page.evaluate("meshplanReport.ready")
            assert pg.page.evaluate("meshplanReport.error")
            assert message in pg.page.locator("#model3d").inner_text()
            assert any("3D view could not be drawn" in e for e in pg.errors), pg.errors
            assert pg.page.locator("#ann-table tbody tr").count() == len(result.annotations)
            assert pg.external_requests() == []
        finally:
            pg.close()
