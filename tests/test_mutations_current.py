"""The mutation script (``scripts/mutate.py``, run on demand) stays applicable: every mutation's
text occurs exactly once in its file, so that code moving elsewhere makes this fail instead of
the mutation going quietly stale."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _mutations():
    spec = importlib.util.spec_from_file_location("meshplan_mutate", ROOT / "scripts" / "mutate.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules.setdefault("meshplan_mutate", module)  # dataclasses look their module up
    spec.loader.exec_module(module)
    return module.MUTATIONS


@pytest.mark.parametrize("mutation", _mutations(), ids=lambda m: m.name)
def test_each_mutation_applies_once(mutation):
    text = (ROOT / "src" / "meshplan" / mutation.file).read_text(encoding="utf-8")
    assert text.count(mutation.old) == 1, f"{mutation.name}: the text to mutate is gone from {mutation.file}"
    assert all((ROOT / t).is_file() for t in mutation.tests)
