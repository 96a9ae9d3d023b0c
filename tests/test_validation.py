"""Validation at the edge (issue 10): every parameter of every stage and every annotation field is
checked for type, shape, range and finiteness before any work, with one message shape; labels
are drawn as plain text everywhere."""

from __future__ import annotations

import dataclasses
import json
import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest
import trimesh
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import box_room
from meshplan.cli import main
from meshplan.errors import AnnotationError, MeshplanError, ParameterError
from meshplan.geometry import Annotations
from meshplan.io.annotations import MAX_ANNOTATIONS, load_annotations, parse_annotations
from meshplan.options import RunOptions
from meshplan.validation import (
    MAX_LABEL_CHARS,
    PARAMETER_CLASSES,
    Integer,
    Real,
    describe,
    plain_text,
    validated,
)

#: Values no parameter of any kind accepts (numbers, choices, flags, lists, optional ones).
HOSTILE = ["ab", math.nan, math.inf, -math.inf, [], {"a": 1}, b"1", object()]


def _groups() -> dict[str, type]:
    """The parameter class of every stage, found from RunOptions (so a new stage is covered)."""
    return {f.name: type(f.default_factory()) for f in dataclasses.fields(RunOptions)}


def _cases() -> list[tuple[type, str, Any]]:
    """Every field of every parameter class, with every value it must refuse."""
    out = []
    for klass in sorted(set(_groups().values()) | set(PARAMETER_CLASSES), key=lambda k: k.__name__):
        constraints = klass._parameter_constraints
        for f in dataclasses.fields(klass):
            for value in HOSTILE + constraints[f.name].invalid_examples():
                out.append((klass, f.name, value))
    return out


def _one_line(exc: MeshplanError) -> str:
    assert exc.message and "\n" not in exc.message and exc.problem and exc.hint, exc.message
    return exc.message


def test_every_stage_is_validated():
    """Each stage's parameter class goes through the one validator, with a constraint for each
    of its fields (the decorator refuses a class that misses one at import)."""
    for group, klass in _groups().items():
        assert klass in PARAMETER_CLASSES, f"{group}: {klass.__name__} is not @validated"
        assert set(klass._parameter_constraints) == {f.name for f in dataclasses.fields(klass)}
    assert len(RunOptions.names()) == sum(len(dataclasses.fields(k)) for k in _groups().values())


@pytest.mark.parametrize(
    "klass, name, value",
    _cases(),
    ids=lambda v: v.__name__ if isinstance(v, type) else v if isinstance(v, str) else describe(v)[:30],
)
def test_every_parameter_refuses_wrong_values_in_one_line(klass, name, value):
    """Wrong type, NaN, infinity, out of range, wrong shape: one line naming the parameter, what
    is allowed and the value, from the dataclass and from the flat keywords alike."""
    with pytest.raises(ParameterError) as exc:
        klass(**{name: value})
    message = _one_line(exc.value)
    assert message.startswith(f"{name} must be "), message
    assert klass._parameter_constraints[name].describe() in message
    assert ", got " in message
    if value is None:  # None means "not given" in the flat keywords (the CLI passes every option)
        return
    with pytest.raises(ParameterError) as flat:
        RunOptions.from_kwargs(**{name: value})
    assert flat.value.message == message


def test_defaults_and_normalised_values():
    """Defaults pass; accepted values come out as plain Python values (JSON-ready)."""
    opts = RunOptions.from_kwargs(slices=np.int64(7), opacity=1, door_width_m=[0.5, 1], gravity_cones_deg=np.array([20.0, 5.0]), max_faces=None)
    assert type(opts.plan.slices) is int and opts.plan.slices == 7
    assert type(opts.render.opacity) is float
    assert opts.plan.door_width_m == (0.5, 1.0) and type(opts.plan.door_width_m[0]) is float
    assert opts.orient.gravity_cones_deg == (20.0, 5.0)
    json.dumps(opts.to_dict())
    # replace() validates too
    with pytest.raises(ParameterError, match="slices must be"):
        dataclasses.replace(opts.plan, slices=0)


def test_bounds_of_options_that_multiply_work():
    for kw, words in [
        ({"slices": 1001}, "slices must be an integer from 1 to 1,000 (more slices add nothing visible"),
        ({"level_bucket_m": 1e-300}, "level_bucket_m must be a number from 0.001 to 0.5"),
        ({"scale": 1}, "scale must be 0 (automatic) or an integer n from 10 to 100,000"),
        ({"floor_cell_m": 1e-6}, "floor_cell_m must be a number from 0.01 to 1"),
        ({"box_length_m": 1e3}, "box_length_m must be a number from 0.001 to 10"),
        ({"gravity_cones_deg": [80.0 - i for i in range(21)]}, "1 to 20 decreasing numbers"),
        ({"processes": 10**6}, "processes must be an integer from 0 to 64"),
    ]:
        with pytest.raises(ParameterError) as exc:
            RunOptions.from_kwargs(**kw)
        assert words in _one_line(exc.value), exc.value.message


def test_fields_tied_together():
    with pytest.raises(ParameterError) as exc:
        RunOptions.from_kwargs(min_room_height_m=3.0, max_story_height_m=2.5)
    assert "max_story_height_m (2.5) must exceed min_room_height_m (3)" in _one_line(exc.value)
    with pytest.raises(ParameterError, match="orient must be a OrientParams"):
        RunOptions(orient={"up": "+z"})


def test_did_you_mean():
    with pytest.raises(ParameterError) as exc:
        RunOptions.from_kwargs(slics=50)
    assert _one_line(exc.value) == "unknown option 'slics'; did you mean 'slices'?"
    with pytest.raises(ParameterError) as exc:
        RunOptions.from_kwargs(box_lenght_m=0.5)
    assert "did you mean 'box_length_m'?" in exc.value.message
    with pytest.raises(ParameterError) as exc:
        RunOptions.from_kwargs(gravity_method="kmean")
    assert exc.value.message == "gravity_method must be one of kmeans, bbox, got 'kmean'; did you mean 'kmeans'?"
    with pytest.raises(ParameterError) as exc:
        RunOptions.from_kwargs(zzzzzz=1)
    assert exc.value.message == "unknown option 'zzzzzz'; see meshplan run --help"


def test_a_parameter_class_without_a_constraint_is_refused():
    with pytest.raises(TypeError, match=r"missing \['b'\]"):

        @validated
        @dataclass(frozen=True)
        class Incomplete:
            _parameter_constraints: ClassVar[dict] = {"a": Integer(0, 1)}
            a: int = 0
            b: float = 1.0

    with pytest.raises(ParameterError, match="a must be"):  # a default outside its own bounds

        @validated
        @dataclass(frozen=True)
        class BadDefault:
            _parameter_constraints: ClassVar[dict] = {"a": Real(0.0, 1.0)}
            a: float = 2.0

    PARAMETER_CLASSES[:] = [k for k in PARAMETER_CLASSES if k.__module__ != __name__]


def test_values_are_described_without_huge_text():
    assert describe(10**5000) == "an integer of about 5001 digits"
    deep: list = []
    for _ in range(100_000):
        deep = [deep]
    assert describe(deep) == "[[...]]"
    assert describe("x" * 1000) == repr("x" * 40) + "..."
    assert "\n" not in describe("a\nb")


# --------------------------------------------------------------------------------------------
# annotations

GOOD = {"label": "S1", "kind": "sensor", "position": [1, 2, 3]}


def _item(**kw) -> str:
    return json.dumps({"annotations": [{**GOOD, **kw}]})


def _hostile_files() -> list[tuple[str, str | bytes, str]]:
    """(name, file content, words of the one-line error)."""
    big = "9" * 400
    return [
        ("huge integer", _item(position=[0, 0, 0]).replace("[0, 0, 0]", f"[{big}, 0, 0]"), "'position' has a coordinate beyond"),
        ("unparsable integer", _item(position=[0, 0, 0]).replace("[0, 0, 0]", f"[{'9' * 5000}, 0, 0]"), "a number of more than 4,300 digits"),
        ("1e308", _item(position=[1e308, 0, 0]), "'position' has a coordinate beyond"),
        ("1e400", _item(position=[0, 0, 0]).replace("[0, 0, 0]", "[1e400, 0, 0]"), "NaN or infinite"),
        ("NaN", _item(position=[0, 0, 0]).replace("[0, 0, 0]", "[0, NaN, 0]"), "NaN or infinite"),
        ("Infinity direction", _item(direction=[0, 0, 0]).replace('"direction": [0, 0, 0]', '"direction": [-Infinity, 0, 0]'), "NaN or infinite"),
        ("nested position", _item(position=[[0], 0, 0]), "'position' must be a list of three numbers, got [[...], 0, 0]"),
        ("bool coordinate", _item(position=[True, 0, 0]), "list of three numbers"),
        ("deep lists", "[" * 100_000 + "]" * 100_000, "JSON nested too deeply"),
        ("deep objects", '{"a":' * 100_000 + "1" + "}" * 100_000, "JSON nested too deeply"),
        ("deep inside", '{"annotations": [' + "[" * 100_000 + "]" * 100_000 + "]}", "JSON nested too deeply"),
        ("NUL in label", _item(label="a\x00b"), "the control character U+0000 at position 2"),
        ("newline in label", _item(label="a\nb"), "the control character U+000A"),
        ("lone surrogate", _item(label="a\ud800"), "a lone surrogate U+D800"),
        ("non-character", _item(label="a\uffff"), "a non-character U+FFFF"),
        ("long label", _item(label="x" * (MAX_LABEL_CHARS + 1)), f"more than the {MAX_LABEL_CHARS} allowed"),
        ("blank label", _item(label="  "), "non-empty string"),
        ("label a list", _item(label=["S1"]), "'label' must be a non-empty string, got ['S1']"),
        ("kind typo", _item(kind="sensr"), 'unknown kind "sensr"; use one of sensor, thermostat, window, door, other (did you mean \'sensor\'?)'),
        ("kind a list", _item(kind=["sensor"]), "unknown kind ['sensor']"),
        ("field typo", json.dumps({"annotations": [{"label": "S1", "kind": "sensor", "positon": [0, 0, 0]}]}), "did you mean 'position' for 'positon'?"),
        ("too many", json.dumps({"annotations": [{**GOOD, "label": f"S{i}"} for i in range(MAX_ANNOTATIONS + 1)]}), "10,001 annotations, more than the 10,000 allowed"),
        ("not UTF-8", b'{"annotations": [{"label": "\xff"}]}', "save it as UTF-8 JSON"),
        ("annotations an object", '{"annotations": {"a": 1}}', '"annotations" must be a list, got an object of 1 keys'),
    ]


@pytest.mark.parametrize("name, content, words", _hostile_files(), ids=[c[0] for c in _hostile_files()])
def test_hostile_annotation_files_are_refused_in_one_line(tmp_path, name, content, words):
    path = tmp_path / "annotations.json"
    # (json.dumps writes NUL, surrogates and U+FFFF as \u escapes: the files are valid UTF-8)
    path.write_bytes(content if isinstance(content, bytes) else content.encode("utf-8"))
    with pytest.raises(AnnotationError) as exc:
        load_annotations(path)
    assert words in _one_line(exc.value), exc.value.message


def test_good_annotations_at_the_limits(tmp_path):
    doc = {"annotations": [
        {"label": "é" * MAX_LABEL_CHARS, "kind": "sensor", "position": [1e7, -1e7, 0], "direction": [10**400, 1e308, 0]},
        {"label": "$x^2$ <&> 50%", "kind": "door", "position": [0, 0, 0], "direction": [5e-324, 0, 0]},
    ]}
    ann = parse_annotations(doc)
    assert np.allclose(ann.directions, [[1, 0, 0], [1, 0, 0]])
    with pytest.raises(AnnotationError, match="beyond 1e\\+07"):
        parse_annotations({"annotations": [{**GOOD, "position": [1e7 + 1, 0, 0]}]})
    # the bound is in metres: the same coordinates in millimetres are 1000 times smaller
    assert parse_annotations({"annotations": [{**GOOD, "position": [1e9, 0, 0]}]}, scale_to_m=0.001).positions[0, 0] == 1e6


_json = st.recursive(
    st.none() | st.booleans() | st.integers() | st.integers(-(10**400), 10**400) | st.floats() | st.text(max_size=8)
    | st.sampled_from(["sensor", "door", "", " ", "\x00", "\ud800", "$x^2$"]),
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.sampled_from(["label", "kind", "position", "direction", "annotations", "x"]) | st.text(max_size=3), inner, max_size=5),
    max_leaves=16,
)
_numbers = st.integers() | st.integers(-(10**400), 10**400) | st.floats() | st.just(1e308) | st.just(5e-324)
_items = st.fixed_dictionaries(
    {"label": st.text(max_size=6) | _json, "kind": st.sampled_from(["sensor", "thermostat", "window", "door", "other", "lamp"]) | _json},
    optional={"position": st.lists(_numbers, min_size=2, max_size=4) | _json, "direction": st.lists(_numbers, min_size=3, max_size=3) | _json},
)


@pytest.fixture
def cases(record_property):
    """Counts the generated cases (reported in the pytest summary, see conftest.py)."""
    count = [0]
    yield count
    record_property("hypothesis_cases", count[0])
    assert count[0] >= 500, f"hypothesis ran {count[0]} cases"


@pytest.mark.hypothesis_cases(500)
@settings(max_examples=800, suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(doc=st.fixed_dictionaries({"annotations": st.lists(_items, max_size=5)}) | _json)
def test_fuzz_parse_annotations_returns_or_raises_a_meshplan_error(cases, doc):
    """Any JSON value: annotations (finite, in metres) or a one-line MeshplanError, nothing else."""
    cases[0] += 1
    try:
        ann = parse_annotations(doc, "ann.json")
    except MeshplanError as exc:
        _one_line(exc)
    else:
        assert np.all(np.isfinite(ann.positions)) and np.all(np.abs(ann.positions) <= 1e7)
        assert all(not np.any(np.isfinite(d)) or abs(np.linalg.norm(d) - 1) < 1e-9 for d in ann.directions)
        assert all(plain_text(label) == label for label in ann.labels)


# --------------------------------------------------------------------------------------------
# labels as plain text

HOSTILE_LABEL = "$x^2$<&>\x00 $\\foo$ 50%%c ^J"
LITERAL = "$x^2$<&> $\\foo$ 50%%c ^J"


def _plan_with_label(label: str):
    from meshplan.orient.stories import Story
    from meshplan.plan.draft import DraftingPlan
    from meshplan.render.params import RenderParams
    from meshplan.render.sheet import make_sheet
    from meshplan.slicing import Slices

    segments = np.array([[[0, 0], [4, 0]], [[4, 0], [4, 3]], [[4, 3], [0, 3]], [[0, 3], [0, 0]]], dtype=float)
    story = Story(0, 0.0, 2.5, True, -0.5, 3.0)
    plan = DraftingPlan(story, 1.2, Slices(np.array([1.2]), segments, np.zeros(4, int), np.arange(4)))
    ann = Annotations((label,), ("sensor",), [[2.0, 1.0, 1.5]], [[1.0, 0.0, 0.0]])
    params = RenderParams(dpi=30)
    return plan, ann, make_sheet(segments.reshape(-1, 2), params), params, segments


def test_labels_are_drawn_as_plain_text_in_valid_svg():
    from meshplan.render.plans import drafting_figure
    from meshplan.render.sheet import figure_bytes

    plan, ann, sheet, params, _ = _plan_with_label(HOSTILE_LABEL)
    svg = figure_bytes(drafting_figure(plan, ann, sheet, params), "svg")
    root = ET.fromstring(svg)  # valid XML: no NUL, "<&>" escaped
    texts = ["".join(el.itertext()) for el in root.iter() if el.tag.endswith("text")]
    assert LITERAL in texts, texts
    # the raster formats draw it too (mathtext would fail on \foo)
    assert figure_bytes(drafting_figure(plan, ann, sheet, params), "png")[:4] == b"\x89PNG"


def test_labels_are_written_literally_in_dxf():
    import ezdxf
    from ezdxf.tools.text import plain_text as dxf_plain_text

    from meshplan.export.dxf import drafting_dxf

    _, ann, _, _, segments = _plan_with_label(HOSTILE_LABEL)
    data = drafting_dxf(segments, segments, ann)
    assert b"\x00" not in data
    doc = ezdxf.read(__import__("io").StringIO(data.decode("utf-8")))
    texts = [e.dxf.text for e in doc.modelspace().query("TEXT")]
    # a CAD program decodes carets and %% codes: what it shows is the label as given
    shown = [dxf_plain_text(t + " ") for t in texts]  # (ezdxf strips a trailing caret)
    assert f"{LITERAL} (sensor) " in shown, texts


# --------------------------------------------------------------------------------------------
# the command line


@pytest.fixture(scope="module")
def small_scan(tmp_path_factory) -> Path:
    v, f = box_room(4.0, 3.0, 2.5, cell=0.5)
    path = tmp_path_factory.mktemp("scan") / "room.ply"
    path.write_bytes(trimesh.Trimesh(v, f, process=False).export(file_type="ply"))
    return path


@pytest.mark.parametrize(
    "setting, words",
    [
        ("slices=[1,2]", "slices must be an integer from 1 to 1,000"),
        ("box_length_m=ab", "box_length_m must be a number from 0.001 to 10, got 'ab'"),
        ("gravity_cones_deg=[]", "gravity_cones_deg must be a schedule of angles"),
        ("level_bucket_m=1e-300", "level_bucket_m must be a number from 0.001 to 0.5"),
        ("opacity=NaN", "opacity must be a number greater than 0 and at most 1"),
        ("dpi=Infinity", "dpi must be an integer from 30 to 1,200"),
        ("min_points=-3", "min_points must be an integer from 1"),
        ("scale=1", "scale must be 0 (automatic)"),
        ("gravity_plane_fit=yes", "gravity_plane_fit must be true or false, got 'yes'"),
        ("slics=3", "unknown option 'slics'; did you mean 'slices'?"),
    ],
)
def test_cli_bad_set_values_exit_2_with_one_line(tmp_path, small_scan, capsys, setting, words):
    out = tmp_path / "out"
    code = main(["run", str(small_scan), "-o", str(out), "--quiet", "--set", setting])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith("error: ") and words in err[0], err
    assert not out.exists()


@pytest.mark.parametrize("name, content", [(n, c) for n, c, _ in _hostile_files() if n in ("huge integer", "deep lists", "1e308", "NUL in label", "too many")])
def test_cli_hostile_annotations_exit_2_with_one_line(tmp_path, small_scan, capsys, name, content):
    ann = tmp_path / "annotations.json"
    ann.write_text(content, encoding="utf-8")
    out = tmp_path / "out"
    code = main(["run", str(small_scan), "-a", str(ann), "-o", str(out), "--quiet"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and err[0].startswith(f"error: {ann}"), err
    assert not out.exists()


@pytest.mark.parametrize("setting", ["slices=" + "9" * 5000, "door_width_m=" + "[" * 100_000 + "]" * 100_000])
def test_cli_set_values_json_cannot_parse(tmp_path, small_scan, capsys, setting):
    code = main(["run", str(small_scan), "-o", str(tmp_path / "out"), "--quiet", "--set", setting])
    assert code == 2


def test_forced_scale_that_makes_a_huge_page_is_refused():
    """--scale 10 on a 100 m building would be a 10 m page: refused in one line naming a scale
    that fits; the automatic scale and a sensible forced one are accepted."""
    import numpy as np

    from meshplan.errors import ParameterError
    from meshplan.render.params import RenderParams
    from meshplan.render.sheet import MAX_PAGE_M, make_sheet

    pts = np.array([[0.0, 0.0], [100.0, 40.0]])
    with pytest.raises(ParameterError, match=r"scale 1:10 .* page .*pass --scale 50 or larger"):
        make_sheet(pts, RenderParams(scale=10))
    assert make_sheet(pts, RenderParams(scale=50)).scale == 50
    auto = make_sheet(pts, RenderParams(scale=0))
    assert (auto.xmax - auto.xmin) / auto.scale <= MAX_PAGE_M
