"""A figure drawn once for its PNG, SVG and PDF (:mod:`meshplan.render.vector`): the PNG holds
matplotlib's own Agg pixels, the SVG and PDF are well formed and show the same texts, paths
and images, byte for byte the same from one run to the next; and the GLB models written
without trimesh (:mod:`meshplan.export.glb`) open in trimesh as they did."""

from __future__ import annotations

import io
import re
import xml.etree.ElementTree as ET
import zlib

import numpy as np
import pytest

from meshplan.render.vector import figure_files, png_bytes, single_colour

SVG = "{http://www.w3.org/2000/svg}"


def _figure():
    """A small figure with what the plans draw: texts (rotated, bold, on a halo), a hatched
    and a dashed path, markers, a legend and a translucent raster."""
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    from meshplan.render.placement import with_halo
    from meshplan.render.sheet import place_raster

    fig = Figure(figsize=(4.0, 3.0), dpi=100)
    ax = fig.add_axes((0.15, 0.15, 0.7, 0.7))
    ax.set_zorder(2)
    ax.patch.set_alpha(0.0)
    ax.set_xlim(0, 10)
    ax.set_ylim(0, 10)
    ax.plot([1, 9], [1, 9], ls="--", lw=0.8, color="#d62728", label="dashed")
    ax.plot([2, 5], [8, 8], marker="D", ls="none", color="#1f77b4", label="markers")
    ax.add_patch(Rectangle((6, 1), 3, 2, facecolor="white", edgecolor="#c0392b", hatch="////", label="hatched"))
    with_halo(ax.text(5, 5, "Room 1\n12.50 m²", ha="center", va="center", fontsize=7))
    ax.text(2, 4, "3.66", rotation=90, rotation_mode="anchor", fontsize=5.5)
    fig.text(0.05, 0.95, "Title (bold)", weight="bold", fontsize=9, va="top")
    ax.legend(loc="lower right", fontsize=5)
    rgba = np.zeros((60, 80, 4), dtype=np.uint8)
    rgba[..., :3] = (20, 33, 61)
    rgba[10:50, 10:70, 3] = np.round(255 * (1 - 0.5 ** np.arange(1, 61)))  # the ink's opacities, 1 - 0.5^k
    place_raster(fig, ax, rgba)
    return fig


def _png_pixels(data: bytes) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(io.BytesIO(data)).convert("RGBA"))


def test_png_is_matplotlibs_own_drawing():
    """The PNG's pixels are those matplotlib's savefig draws, every one."""
    ours = figure_files(_figure(), ("png",))["png"]
    buf = io.BytesIO()
    _figure().savefig(buf, format="png")
    np.testing.assert_array_equal(_png_pixels(ours), _png_pixels(buf.getvalue()))
    assert b"Software\x00meshplan" in ours


def test_figure_drawn_once_for_three_formats(monkeypatch):
    from matplotlib.figure import Figure

    calls = []
    original = Figure.draw

    def counted(self, renderer):
        calls.append(type(renderer).__name__)
        return original(self, renderer)

    monkeypatch.setattr(Figure, "draw", counted)
    files = figure_files(_figure(), ("png", "svg", "pdf"))
    assert sorted(files) == ["pdf", "png", "svg"]
    assert calls == ["PlanRenderer"]


def test_files_are_byte_reproducible():
    a = figure_files(_figure(), ("png", "svg", "pdf"))
    b = figure_files(_figure(), ("png", "svg", "pdf"))
    assert a == b


def test_svg_is_valid_and_holds_the_drawing():
    svg = figure_files(_figure(), ("svg",))["svg"]
    root = ET.fromstring(svg)
    assert root.get("viewBox") == "0 0 288 216"  # 4 x 3 inches in points
    texts = ["".join(el.itertext()) for el in root.iter(f"{SVG}text")]
    for want in ("Room 1", "12.50 m²", "3.66", "Title (bold)", "dashed", "markers", "hatched"):
        assert want in texts, (want, texts)
    bold = [el for el in root.iter(f"{SVG}text") if "".join(el.itertext()) == "Title (bold)"]
    assert "font-weight: 700" in bold[0].get("style")
    # every reference is defined: clip paths, the hatch pattern
    ids = {el.get("id") for el in root.iter() if el.get("id")}
    refs = set(re.findall(rb"url\(#([^)]+)\)", svg))
    assert refs and {r.decode() for r in refs} <= ids
    assert any(el.tag == f"{SVG}pattern" for el in root.iter())
    styles = " ".join(el.get("style", "") for el in root.iter(f"{SVG}path"))
    assert "stroke-dasharray" in styles
    # the raster, of one colour: a palette PNG
    images = list(root.iter(f"{SVG}image"))
    assert len(images) == 1
    href = images[0].get("{http://www.w3.org/1999/xlink}href")
    png = __import__("base64").b64decode(href.split(",", 1)[1])
    assert png[25] == 3  # colour type: palette
    assert float(images[0].get("width")) == pytest.approx(80 * 72 / 100)


def _pdf_objects(pdf: bytes) -> dict[int, bytes]:
    """The objects of a PDF, by number, found through its cross-reference table."""
    start = int(pdf.rsplit(b"startxref", 1)[1].split()[0])
    assert pdf[start : start + 4] == b"xref"
    lines = pdf[start:].split(b"\n")
    count = int(lines[1].split()[1])
    out = {}
    for i in range(1, count):
        offset = int(lines[2 + i][:10])
        assert pdf[offset:].startswith(f"{i} 0 obj".encode()), i
        out[i] = pdf[offset : pdf.index(b"endobj", offset)]
    return out


def _stream(obj: bytes) -> bytes:
    data = obj[obj.index(b"stream\n") + 7 : obj.rindex(b"\nendstream")]
    return zlib.decompress(data) if b"/FlateDecode" in obj else data


def test_pdf_is_well_formed_and_its_text_extractable():
    """Every object where the cross-reference table says, a page of the figure's size, the
    texts shown with Type 3 fonts whose ToUnicode maps give their characters back."""
    pdf = figure_files(_figure(), ("pdf",))["pdf"]
    assert pdf.startswith(b"%PDF-1.4") and pdf.rstrip().endswith(b"%%EOF")
    objects = _pdf_objects(pdf)
    assert b"/MediaBox [0 0 288 216]" in objects[3]
    fonts = {i: o for i, o in objects.items() if b"/Subtype /Type3" in o}
    assert fonts
    # decode the page's hex strings through the fonts' maps
    maps = {}
    for o in fonts.values():
        ref = int(re.search(rb"/ToUnicode (\d+) 0 R", o).group(1))
        cmap = _stream(objects[ref]).decode()
        maps[o] = {int(a, 16): chr(int(b, 16)) for a, b in re.findall(r"<([0-9a-f]{2})> <([0-9a-f]{4})>", cmap)}
    page = dict(re.findall(rb"/(F\d+) (\d+) 0 R", objects[3]))
    content = _stream(objects[4]).decode("latin-1")
    shown = []
    font = None
    for token in re.finditer(r"/(F\d+) [\d.]+ Tf|<([0-9a-f]+)>", content):
        if token.group(1):
            font = maps[objects[int(page[token.group(1).encode()])]]
        else:
            h = token.group(2)
            shown.append("".join(font[int(h[i : i + 2], 16)] for i in range(0, len(h), 2)))
    text = "".join(shown)
    for want in ("Room1", "12.50m²", "3.66", "Title(bold)", "hatched"):
        assert want in text.replace(" ", ""), (want, text)
    # the raster: one pixel of its colour under a soft mask of its opacity
    images = [o for o in objects.values() if b"/Subtype /Image" in o and b"/SMask" in o]
    assert len(images) == 1 and b"/Width 1 /Height 1" in images[0]
    assert b"/Pattern" in objects[3]  # the hatch


def test_png_bytes_and_single_colour():
    rgba = np.zeros((5, 7, 4), dtype=np.uint8)
    rgba[..., 0] = np.arange(7)
    rgba[..., 3] = 255
    np.testing.assert_array_equal(_png_pixels(png_bytes(rgba, 150)), rgba)
    assert single_colour(rgba) is None
    ink = np.zeros((4, 4, 4), dtype=np.uint8)
    ink[1:3, 1:3] = (20, 33, 61, 128)
    assert single_colour(ink).tolist() == [20, 33, 61]


def test_a_mesh_falls_back_to_matplotlib():
    """A primitive the writers do not know (a quad mesh) leaves the vector files to matplotlib."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(2, 2), dpi=50)
    fig.add_axes((0.1, 0.1, 0.8, 0.8)).pcolormesh(np.arange(12.0).reshape(3, 4))
    files = figure_files(fig, ("png", "svg", "pdf"))
    assert files["pdf"].startswith(b"%PDF") and b"<svg" in files["svg"] and files["png"][:4] == b"\x89PNG"


def test_glb_models_open_in_trimesh():
    """The GLB writer's scene: the mesh and a marker per annotation, each a node with its name
    and one colour on every vertex; markers closed, turned outwards."""
    import trimesh

    from meshplan.export.glb import MESH_RGBA, glb_bytes
    from meshplan.geometry import Annotations, Mesh

    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], dtype=float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    ann = Annotations(("S1", "T1"), ("sensor", "thermostat"), np.array([[2.0, 0, 0], [3.0, 0, 0]]), np.array([[0.0, 1, 0], [np.nan] * 3]))
    scene = trimesh.load(io.BytesIO(glb_bytes(Mesh(v, f), ann, "scan")), file_type="glb")
    assert sorted(scene.geometry) == ["S1 (sensor)", "T1 (thermostat)", "scan"]
    mesh = scene.geometry["scan"]
    assert len(mesh.faces) == 4 and np.allclose(mesh.bounds, [[0, 0, 0], [1, 1, 1]])
    assert tuple(mesh.visual.vertex_colors[0]) == MESH_RGBA
    sphere, probe = scene.geometry["T1 (thermostat)"], scene.geometry["S1 (sensor)"]
    assert len(sphere.vertices) == 162 and len(sphere.faces) == 320  # trimesh's icosphere(subdivisions=2)
    for m in (sphere, probe):
        assert m.is_watertight and m.volume > 0
    assert probe.bounds[1][1] > 0.3  # the probe along +y
