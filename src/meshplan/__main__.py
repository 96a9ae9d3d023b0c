"""``python -m meshplan``."""

from .cli import entry

entry()
