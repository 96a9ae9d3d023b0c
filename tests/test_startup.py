"""Start-up (issue 15): ``meshplan --version`` and ``meshplan run --help`` load the parameter
classes only, not the stages. Checked by what a fresh interpreter has imported (a benchmark
measures the time, ``make bench``), and the stage packages' lazy names all resolve."""

from __future__ import annotations

import importlib
import json
import pkgutil
import subprocess
import sys

import pytest

#: What the help defaults must not load: the numba kernels, the plotting library, the heavy
#: parts of scipy, the stages themselves, and numpy (the defaults are plain numbers: numpy and
#: the readers importing it were a third of ``meshplan run --help``'s 0.39 s).
HEAVY = ("numpy", "numba", "matplotlib", "scipy.spatial", "scipy.sparse", "shapely", "trimesh", "meshplan.walls.flat", "meshplan.plan.rooms")

LAZY_PACKAGES = ("meshplan.orient", "meshplan.walls", "meshplan.plan", "meshplan.io", "meshplan.render")


def test_the_command_line_loads_no_stage_to_print_its_help():
    code = (
        "import json, sys\n"
        "from meshplan.cli import app\n"
        "from typer.main import get_command\n"
        "cmd = get_command(app)\n"
        "ctx = cmd.make_context('meshplan', ['run', '--help'], resilient_parsing=True)\n"
        "print(json.dumps(sorted(sys.modules)))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120, check=True).stdout
    loaded = set(json.loads(out.strip().splitlines()[-1]))
    assert not [m for m in HEAVY if m in loaded]


@pytest.mark.parametrize("package", LAZY_PACKAGES)
def test_lazy_names_resolve_and_no_submodule_shadows_one(package):
    """Every name a lazy package lists loads; none is also the name of one of its submodules
    (importing that submodule would replace the name by the module on the package)."""
    pkg = importlib.import_module(package)
    table = pkg._EXPORTS
    assert set(pkg.__all__) == set(table) | ({"RenderParams"} if package == "meshplan.render" else set())
    subs = {m.name for m in pkgutil.iter_modules(pkg.__path__)}
    assert not subs & set(table)
    for name in table:
        assert getattr(pkg, name) is not None
