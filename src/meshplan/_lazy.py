"""Packages that load their names when first used (PEP 562).

``meshplan --version`` and ``meshplan run --help`` read the stages' parameter classes (the
defaults of the options) and nothing else; a package ``__init__`` that imported every stage
module would load numba, scipy and matplotlib to print them (about a second). Each stage package
lists where its public names live and loads a submodule when one of them is first used; type
checkers read the same names from the ``if TYPE_CHECKING:`` imports beside the table.
"""

from __future__ import annotations

from collections.abc import Callable
from importlib import import_module
from typing import Any


def lazy_exports(package: str, table: dict[str, str], namespace: dict[str, Any]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` whose public names live in the submodules
    ``table`` gives (name -> submodule); ``namespace`` is the package's ``globals()``, where a
    name, once loaded, stays as an ordinary attribute."""

    def __getattr__(name: str) -> Any:
        module = table.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(import_module(f".{module}", package), name)
        namespace[name] = value
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(table))

    return __getattr__, __dir__
