"""meshplan: from a scanned triangle mesh of a building interior to an oriented 3D model and floor plans."""

from ._version import __version__
from .errors import MeshplanError

__all__ = ["MeshplanError", "__version__"]
