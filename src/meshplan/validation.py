"""Validation at the edge: parameter constraints declared as data, and the rules for label text.

Every parameter dataclass (:class:`meshplan.orient.OrientParams`, ...) declares, scikit-learn
style, one constraint per field in a class-level ``_parameter_constraints`` dict and is decorated
with :func:`validated`, which refuses (at import time) a class whose constraints do not cover
exactly its fields and makes its ``__post_init__`` check every value before any work is done::

    @validated
    @dataclass(frozen=True)
    class PlanParams:
        _parameter_constraints: ClassVar[dict[str, Constraint]] = {
            "slices": Integer(1, MAX_SLICES, why="..."),
        }
        slices: int = 100

A wrong value raises :class:`meshplan.errors.ParameterError` with one message shape::

    slices must be an integer from 1 to 1000 (<why>), got 5000; pass e.g. slices=100 (the default)

naming the parameter, what is allowed, and the value (described without ever printing a huge
integer or a deep list in full). Valid values are normalised: integers to ``int``, numbers to
``float`` (so that numpy scalars and ``1`` for a float reach ``plan.json`` as plain JSON), lists
to tuples.

The label rules (:func:`label_problem`, :func:`plain_text`) live here too: annotation files are
refused when a label breaks them, and every writer passes labels through :func:`plain_text` so
that labels made in Python are drawn literally as well.

Why one long module: the constraint classes, the decorator and the label rules form one small
library used by every parameter class; splitting it would only move imports around.
"""

from __future__ import annotations

import dataclasses
import difflib
import functools
import json
import math
import numbers
from collections.abc import Callable, Sequence
from typing import Any

from .errors import ParameterError

#: Longest length in metres any length parameter may have: 1 km is larger than any building, so
#: a longer length is a unit mistake; it also keeps grid sizes (length / cell) far from overflow.
MAX_LENGTH_M = 1000.0

#: Longest label, in characters. IFC4 names (``IfcLabel``) hold at most 255 characters, and the
#: DXF label adds `` (<kind>)``; 200 leaves room for both, so no writer ever truncates a label,
#: and 200 characters at the plans' 5.5 pt already run across a whole A3 sheet.
MAX_LABEL_CHARS = 200

#: Most entries a sequence parameter (``gravity_cones_deg``, ...) may list: each entry is one
#: pass of a spherical k-means over every face; the paper uses 5 and 7.
MAX_SCHEDULE_STEPS = 20


# --------------------------------------------------------------------------------------------
# describing values without ever building a huge string


#: Integers with more digits than this are described by their digit count: Python refuses to
#: turn integers of more than 4300 digits into text at all, and nobody reads 40 digits.
_MAX_SHOWN_DIGITS = 20
_MAX_SHOWN_CHARS = 40
_MAX_SHOWN_ITEMS = 4


def describe(value: Any, depth: int = 0) -> str:
    """A short, one-line, bounded description of any value (never recursing more than two
    levels, never converting a huge integer to text)."""
    if isinstance(value, bool) or value is None:
        return repr(value)
    if isinstance(value, numbers.Integral):
        v = int(value)
        digits = int(abs(v).bit_length() * math.log10(2)) + 1
        return repr(v) if digits <= _MAX_SHOWN_DIGITS else f"an integer of about {digits} digits"
    if isinstance(value, numbers.Real):
        return repr(float(value))
    if isinstance(value, str):
        shown = repr(value[:_MAX_SHOWN_CHARS])
        return shown + ("..." if len(value) > _MAX_SHOWN_CHARS else "")
    if isinstance(value, (list, tuple)):
        open_, close = ("[", "]") if isinstance(value, list) else ("(", ")")
        if depth >= 1:
            return f"{open_}...{close}" if value else f"{open_}{close}"
        items = [describe(v, depth + 1) for v in value[:_MAX_SHOWN_ITEMS]]
        if len(value) > _MAX_SHOWN_ITEMS:
            items.append(f"... {len(value)} items")
        return open_ + ", ".join(items) + close
    if isinstance(value, dict):
        return f"an object of {len(value)} keys"
    return f"a {type(value).__name__}"


def _num(x: float) -> str:
    """A bound as people write it: ``1,000`` rather than ``1e+03``, ``0.001`` as is."""
    if float(x).is_integer() and abs(x) < 1e15:
        return f"{int(x):,}"
    return f"{x:g}"


def _example(value: Any) -> str:
    """A default as one would type it after ``--set NAME=`` (JSON, floats to 6 digits)."""
    if isinstance(value, tuple):
        return "[" + ",".join(_example(v) for v in value) + "]"
    if isinstance(value, float):
        return f"{value:.6g}"
    return json.dumps(value)


# --------------------------------------------------------------------------------------------
# constraints


class Constraint:
    """What one parameter may be. Subclasses implement :meth:`convert` (the normalised value, or
    ``None`` when the value is not allowed) and :meth:`describe`."""

    #: Why the bound is what it is, said when a value falls outside it.
    why: str = ""

    def convert(self, value: Any) -> Any | None:  # pragma: no cover - abstract
        raise NotImplementedError

    def describe(self) -> str:  # pragma: no cover - abstract
        raise NotImplementedError

    def hint(self, name: str, value: Any, default: Any) -> str:
        """What to do about a wrong value."""
        if default is None:
            return f"leave {name} unset (the default), or give {self.describe()}"
        return f"pass e.g. {name}={_example(default)} (the default)"

    def invalid_examples(self) -> list[Any]:
        """Values of the right kind that this constraint refuses (for the tests)."""
        return []

    def type_ok(self, value: Any) -> bool:
        """Whether the value is of the right kind (so that a refusal is about its range)."""
        return False


def _is_real(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


class Real(Constraint):
    """A finite real number in an interval.

    Parameters
    ----------
    low, high
        The bounds; ``None`` for none (the value must still be finite).
    closed
        Which bounds belong to the interval: ``"both"``, ``"left"``, ``"right"`` or ``"neither"``.
    why
        Why the bounds are where they are (shown when a value falls outside them).
    """

    def __init__(self, low: float | None, high: float | None, closed: str = "both", why: str = "") -> None:
        if closed not in ("both", "left", "right", "neither"):
            raise ValueError(f"closed must be both, left, right or neither, got {closed!r}")
        self.low, self.high, self.closed, self.why = low, high, closed, why

    def type_ok(self, value: Any) -> bool:
        return _is_real(value)

    def _in_range(self, v: float) -> bool:
        lo_in = self.closed in ("both", "left")
        hi_in = self.closed in ("both", "right")
        above = self.low is None or (v >= self.low if lo_in else v > self.low)
        below = self.high is None or (v <= self.high if hi_in else v < self.high)
        return above and below

    def convert(self, value: Any) -> float | None:
        if not _is_real(value):
            return None
        if isinstance(value, numbers.Integral):
            # compare the exact integer first: float() of a huge integer overflows
            if not self._in_range(int(value)):
                return None
            return float(value)
        v = float(value)
        return v if math.isfinite(v) and self._in_range(v) else None

    def _bounds_text(self, kind: str) -> str:
        lo_in = self.closed in ("both", "left")
        hi_in = self.closed in ("both", "right")
        lo, hi = self.low, self.high
        if lo is not None and hi is not None:
            if lo_in and hi_in:
                return f"{kind} from {_num(lo)} to {_num(hi)}"
            return (
                f"{kind} {'of at least' if lo_in else 'greater than'} {_num(lo)} "
                f"and {'at most' if hi_in else 'below'} {_num(hi)}"
            )
        if lo is not None:
            return f"{kind} {'of at least' if lo_in else 'greater than'} {_num(lo)}"
        if hi is not None:
            return f"{kind} {'of at most' if hi_in else 'below'} {_num(hi)}"
        return f"a finite {kind.removeprefix('a ')}"

    def describe(self) -> str:
        return self._bounds_text("a number")

    def invalid_examples(self) -> list[Any]:
        out: list[Any] = [math.nan, math.inf, -math.inf, 10**400, "1.0", [1.0], True]
        if self.low is not None:
            out.append(self.low if self.closed in ("right", "neither") else self.low - max(abs(self.low), 1.0) * 1e-3)
            out.append(self.low - 1e-300 if self.low == 0 and self.closed in ("both", "left") else self.low - 1)
            out.append(-(10**400))
        if self.high is not None:
            out.append(self.high if self.closed in ("left", "neither") else self.high * 1.001 + 1e-9)
        # drop examples that happen to be valid (e.g. low - 1e-300 rounding back to low)
        return [v for v in out if self.convert(v) is None]


class Integer(Real):
    """An integer (not a bool, not a float) in a closed interval."""

    def __init__(self, low: int | None, high: int | None, why: str = "") -> None:
        super().__init__(low, high, "both", why)

    def type_ok(self, value: Any) -> bool:
        return isinstance(value, numbers.Integral) and not isinstance(value, bool)

    def convert(self, value: Any) -> int | None:
        if not self.type_ok(value):
            return None
        v = int(value)
        return v if self._in_range(v) else None

    def describe(self) -> str:
        return self._bounds_text("an integer")

    def invalid_examples(self) -> list[Any]:
        out: list[Any] = [1.5, 2.0, math.nan, "3", [1], True]
        if self.low is not None:
            out += [self.low - 1, -(10**400)]
        if self.high is not None:
            out += [self.high + 1, 10**400]
        return [v for v in out if self.convert(v) is None]


class Options(Constraint):
    """One of a few strings; a wrong one gets a "did you mean"."""

    def __init__(self, values: Sequence[str]) -> None:
        self.values = tuple(values)

    def type_ok(self, value: Any) -> bool:
        return isinstance(value, str)

    def convert(self, value: Any) -> str | None:
        return value if isinstance(value, str) and value in self.values else None

    def describe(self) -> str:
        return "one of " + ", ".join(self.values)

    def hint(self, name: str, value: Any, default: Any) -> str:
        close = difflib.get_close_matches(value, self.values, n=1) if isinstance(value, str) else []
        return f"did you mean {close[0]!r}?" if close else f"use one of {', '.join(self.values)}"

    def invalid_examples(self) -> list[Any]:
        return ["not-an-option", "", self.values[0].upper() + "?", 1, None]


class Boolean(Constraint):
    """``True`` or ``False`` (not 0, 1 or "yes": ``--set NAME=true``)."""

    def type_ok(self, value: Any) -> bool:
        return isinstance(value, bool) or type(value).__name__ == "bool_"

    def convert(self, value: Any) -> bool | None:
        return bool(value) if self.type_ok(value) else None

    def describe(self) -> str:
        return "true or false"

    def invalid_examples(self) -> list[Any]:
        return [0, 1, "yes", "true", None]


class Numbers(Constraint):
    """A list of finite numbers, each allowed by ``item``.

    Parameters
    ----------
    item
        The constraint on each number.
    length
        The exact number of entries, or ``(min, max)``.
    order
        ``"increasing"`` or ``"decreasing"`` (not strictly), or ``None``.
    what
        How to call such a list in messages, e.g. ``"a range [min, max]"``.
    """

    def __init__(self, item: Real, length: int | tuple[int, int], order: str | None = None, what: str = "a list", why: str = "") -> None:
        self.item, self.order, self.what, self.why = item, order, what, why
        self.length = (length, length) if isinstance(length, int) else length

    def type_ok(self, value: Any) -> bool:
        return isinstance(value, (list, tuple))

    def convert(self, value: Any) -> tuple | None:
        if hasattr(value, "tolist") and not isinstance(value, (list, tuple)):  # a numpy array
            value = value.tolist()
        if not isinstance(value, (list, tuple)) or not self.length[0] <= len(value) <= self.length[1]:
            return None
        items: list[float] = []
        for v in value:
            item = self.item.convert(v)
            if item is None:
                return None
            items.append(item)
        if self.order == "decreasing" and items != sorted(items, reverse=True):
            return None
        if self.order == "increasing" and items != sorted(items):
            return None
        return tuple(items)

    def describe(self) -> str:
        lo, hi = self.length
        count = f"{lo}" if lo == hi else f"{lo} to {hi}"
        order = f"{self.order} " if self.order else ""
        return f"{self.what}: {count} {order}numbers, each {self.item.describe().removeprefix('a number ')}"

    def invalid_examples(self) -> list[Any]:
        lo, hi = self.length
        good = self.item.low if self.item.low is not None and self.item.closed in ("both", "left") else 1.0
        out: list[Any] = [[], "ab", 1.0, [math.nan] * lo, [good] * (hi + 1), [[good]] * lo, ["1"] * lo]
        if self.order is not None and lo >= 2 and self.item.low is not None and self.item.high is not None:
            a, b = self.item.low, self.item.high
            pts = [a + (b - a) * 0.25, a + (b - a) * 0.75]
            out.append(pts if self.order == "decreasing" else pts[::-1])
        return [v for v in out if self.convert(v) is None]


class Optional(Constraint):
    """``None`` or a value allowed by ``inner``."""

    def __init__(self, inner: Constraint) -> None:
        self.inner = inner
        self.why = inner.why

    def type_ok(self, value: Any) -> bool:
        return value is None or self.inner.type_ok(value)

    def convert(self, value: Any) -> Any:
        return _NONE if value is None else self.inner.convert(value)

    def describe(self) -> str:
        return f"{self.inner.describe()}, or unset"

    def hint(self, name: str, value: Any, default: Any) -> str:
        if default is None:
            return f"leave {name} unset (the default), or give {self.inner.describe()}"
        return self.inner.hint(name, value, default)

    def invalid_examples(self) -> list[Any]:
        return [v for v in self.inner.invalid_examples() if v is not None]


class AnyOf(Constraint):
    """A value allowed by one of several constraints (e.g. ``0`` for automatic, or 2 to 16)."""

    def __init__(self, *options: Constraint, what: str = "", why: str = "") -> None:
        self.options, self.what, self.why = options, what, why

    def type_ok(self, value: Any) -> bool:
        return any(o.type_ok(value) for o in self.options)

    def convert(self, value: Any) -> Any:
        for o in self.options:
            v = o.convert(value)
            if v is not None:
                return v
        return None

    def describe(self) -> str:
        return self.what or " or ".join(o.describe() for o in self.options)

    def invalid_examples(self) -> list[Any]:
        out = [v for o in self.options for v in o.invalid_examples()]
        return [v for v in out if self.convert(v) is None]


#: What :meth:`Optional.convert` returns for an accepted ``None`` (``None`` means refused).
_NONE = object()


# --------------------------------------------------------------------------------------------
# the validator


#: Every class decorated with :func:`validated` (the tests walk them all).
PARAMETER_CLASSES: list[type] = []


def check_value(name: str, constraint: Constraint, value: Any, default: Any = None) -> Any:
    """The normalised ``value`` of parameter ``name``, or a :class:`ParameterError` in the one
    message shape (parameter, what is allowed, the value; what to do)."""
    converted = constraint.convert(value)
    if converted is _NONE:
        return None
    if converted is not None:
        return converted
    allowed = constraint.describe()
    why = f" ({constraint.why})" if constraint.why and constraint.type_ok(value) else ""
    raise ParameterError(f"{name} must be {allowed}{why}, got {describe(value)}", constraint.hint(name, value, default))


def validate_params(obj: Any) -> None:
    """Check and normalise every field of the frozen parameter dataclass ``obj`` against its
    class's ``_parameter_constraints``, then run its ``_check_together`` (rules that tie several
    fields together), if any."""
    constraints = type(obj)._parameter_constraints
    for f in dataclasses.fields(obj):
        default = f.default if f.default is not dataclasses.MISSING else None
        value = check_value(f.name, constraints[f.name], getattr(obj, f.name), default)
        object.__setattr__(obj, f.name, value)  # frozen: normalising is part of construction
    together: Callable[[], None] | None = getattr(obj, "_check_together", None)
    if together is not None:
        together()


def validated(cls: type) -> type:
    """Class decorator (above ``@dataclass``): validate every field on construction.

    Raises
    ------
    TypeError
        At import time, when ``_parameter_constraints`` does not name exactly the fields (a new
        parameter cannot be added without its constraint).
    """
    constraints: dict[str, Constraint] = cls.__dict__.get("_parameter_constraints", {})
    names = {f.name for f in dataclasses.fields(cls)}
    if set(constraints) != names:
        missing, extra = sorted(names - set(constraints)), sorted(set(constraints) - names)
        raise TypeError(f"{cls.__name__}._parameter_constraints: missing {missing}, unknown {extra}")
    for f in dataclasses.fields(cls):
        if f.default is not dataclasses.MISSING:
            # the defaults themselves must pass (a wrong default is a bug, caught at import)
            check_value(f.name, constraints[f.name], f.default, f.default)
    if "__post_init__" in cls.__dict__:
        raise TypeError(f"{cls.__name__}: put rules tying fields together in _check_together, not __post_init__")
    # wrap the generated __init__ (dataclass looks for __post_init__ only while it builds the
    # class, so one cannot be added afterwards); dataclasses.replace() goes through it as well
    generated = cls.__init__  # type: ignore[misc]

    @functools.wraps(generated)
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        generated(self, *args, **kwargs)
        validate_params(self)

    cls.__init__ = __init__  # type: ignore[misc]
    PARAMETER_CLASSES.append(cls)
    return cls


def unknown_name(name: str, known: Sequence[str], what: str = "option", hint: str = "see meshplan run --help") -> ParameterError:
    """The error for an unknown parameter name, with difflib's closest known name."""
    close = difflib.get_close_matches(name, list(known), n=1, cutoff=0.6)
    return ParameterError(f"unknown {what} {describe(name)}", f"did you mean {close[0]!r}?" if close else hint)


# --------------------------------------------------------------------------------------------
# label text


def _forbidden(ch: str) -> bool:
    """Characters a label may not hold: control characters (C0, DEL, C1: NUL ends C strings and
    XML cannot hold most of them), lone surrogates (no UTF-8 encoding exists) and U+FFFE, U+FFFF
    (not characters; invalid in XML 1.0)."""
    o = ord(ch)
    return o < 0x20 or 0x7F <= o < 0xA0 or 0xD800 <= o <= 0xDFFF or o in (0xFFFE, 0xFFFF)


def label_problem(label: str) -> str | None:
    """What is wrong with ``label`` as an annotation label, or ``None``."""
    if not label.strip():
        return "'label' must be a non-empty string"
    if len(label) > MAX_LABEL_CHARS:
        return f"'label' has {len(label)} characters, more than the {MAX_LABEL_CHARS} allowed"
    for i, ch in enumerate(label):
        if _forbidden(ch):
            what = "a lone surrogate" if 0xD800 <= ord(ch) <= 0xDFFF else "a non-character" if ord(ch) >= 0xFFFE else "the control character"
            return f"'label' holds {what} U+{ord(ch):04X} at position {i + 1}"
    return None


def plain_text(text: str, keep_newlines: bool = False) -> str:
    """``text`` with the characters no label may hold removed: what every writer draws (labels
    made in Python skip :func:`label_problem`). ``keep_newlines`` keeps line breaks, for the
    two-line room labels."""
    return "".join(ch for ch in str(text) if not _forbidden(ch) or (keep_newlines and ch == "\n"))


#: Keyword arguments of matplotlib ``Text`` (``ax.text``, ``ax.annotate``) that draw a string as
#: it is: no mathtext (``$x^2$`` stays dollars and a caret), no LaTeX.
PLAIN_TEXT_KW: dict[str, Any] = {"usetex": False, "parse_math": False}
