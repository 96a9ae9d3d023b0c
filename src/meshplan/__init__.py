"""meshplan: from a scanned triangle mesh of a building interior to an oriented 3D model and floor plans.

>>> import meshplan
>>> result = meshplan.run("scan.obj", output="plans", annotations="annotations.json")  # doctest: +SKIP
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from ._version import __version__
from .errors import MeshplanError

if TYPE_CHECKING:  # pragma: no cover
    from .result import Result

__all__ = ["MeshplanError", "Result", "__version__", "run"]


def run(scan: Any, **options: Any) -> Result:
    """Turn a scanned mesh into an oriented model and floor plans; see :func:`meshplan.api.run`."""
    from .api import run as _run

    return _run(scan, **options)


def __getattr__(name: str) -> Any:
    if name == "Result":
        from .result import Result

        return Result
    raise AttributeError(name)
