"""Scene-file schema: typed keys with units, ranges and documentation, and the validator.

A scene file is TOML. Each key is declared once, as a field of the frozen dataclass that holds its
value (the scene module's ``*Spec`` classes, or a small table class where a TOML table does not map
one-to-one onto the object the code uses): :func:`setting` returns the ``dataclasses.field`` whose
metadata carries the :class:`Key` (the key's name in the file with its unit, e.g. ``module_mm``,
its type, the factor that converts it to SI, its default in file units, its allowed range and its
meaning) and whose dataclass default is that file default converted to SI. :func:`section_of`
derives a TOML table's :class:`Section` from the class. The same declarations drive validation,
the conversion to SI (done once, at load time) and the key reference (``micropit scene
--help-keys``, docs/scenes.md), so neither the documentation nor the dataclass defaults can drift
from what the code accepts.
"""

from __future__ import annotations

import datetime
import difflib
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, fields, replace
from typing import Any

from micropit_hpc.errors import SceneError, format_value


class _Required:
    def __repr__(self) -> str:
        return "REQUIRED"


REQUIRED: Any = _Required()
"""Default of a key that must be given."""

_TYPE_WORDS = {"float": "a number", "int": "an integer", "str": "a string", "bool": "true or false",
               "floats": "a list of numbers"}


@dataclass(frozen=True)
class Key:
    """One scene-file key.

    Declared through :func:`setting` as a dataclass field's metadata; ``attr`` (the field's name,
    the SI attribute) is filled in by :func:`section_of`. ``default`` is in file units; ``None``
    means optional and absent, :data:`REQUIRED` means the key must be given. Numbers are
    multiplied by ``scale`` to give SI values. Bounds ``lo``/``hi`` apply in file units, open
    when ``lo_open``/``hi_open``.
    """

    name: str
    attr: str
    type: str
    doc: str
    unit: str = ""
    scale: float = 1.0
    default: Any = REQUIRED
    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    hi_open: bool = False
    choices: tuple[str, ...] = ()

    def allowed(self) -> str:
        """The allowed values in words, e.g. ``a number > 0 (mm)``."""
        if self.choices:
            return "one of " + ", ".join(f'"{c}"' for c in self.choices)
        what = _TYPE_WORDS[self.type]
        if self.type == "floats":
            what = "a non-empty list of numbers"
        rng = self.range_text()
        unit = f" ({self.unit})" if self.unit else ""
        if not rng:
            return f"{what}{unit}" if self.type in ("float", "floats") else what
        each = ", each" if self.type == "floats" else ""
        return f"{what}{each} {rng}{unit}"

    def range_text(self) -> str:
        lo, hi = self.lo, self.hi
        if lo is not None and hi is not None:
            return (f"in {'(' if self.lo_open else '['}{_num(lo)}, {_num(hi)}"
                    f"{')' if self.hi_open else ']'}")
        if lo is not None:
            return f"{'>' if self.lo_open else '≥'} {_num(lo)}"
        if hi is not None:
            return f"{'<' if self.hi_open else '≤'} {_num(hi)}"
        return ""

    def in_range(self, v: float) -> bool:
        if self.lo is not None and (v < self.lo or (self.lo_open and v == self.lo)):
            return False
        return not (self.hi is not None and (v > self.hi or (self.hi_open and v == self.hi)))


#: name of the dataclass-field metadata entry that holds a setting's :class:`Key`
KEY = "scene_key"


def setting(name: str, type: str, doc: str, unit: str = "", scale: float = 1.0,
            default: Any = REQUIRED, *, lo: float | None = None, hi: float | None = None,
            lo_open: bool = False, hi_open: bool = False, choices: tuple[str, ...] = ()) -> Any:
    """A dataclass field that is a scene key: the key's declaration, the only one.

    The arguments are those of :class:`Key` less ``attr`` (the field's name). The field's
    dataclass default is ``default`` (file units) converted to SI exactly as a file's value is,
    so an omitted key and the dataclass default are the same float; a :data:`REQUIRED` key gives
    a keyword-only field without a default.
    """
    key = Key(name, "", type, doc, unit, scale, default, lo, hi, lo_open, hi_open, choices)
    meta = {KEY: key}
    if default is REQUIRED:
        return field(kw_only=True, metadata=meta)
    si = None if default is None else _convert(key, default, name, "<schema>")
    return field(default=si, metadata=meta)


def keys_of(cls: type) -> tuple[Key, ...]:
    """The keys declared by the fields of a dataclass, in field order, ``attr`` = field name."""
    return tuple(replace(f.metadata[KEY], attr=f.name) for f in fields(cls) if KEY in f.metadata)


@dataclass(frozen=True)
class Section:
    """A TOML table of the scene file (``path`` is dotted, e.g. ``gear.pinion``).

    Made by :func:`section_of` from the dataclass ``cls`` whose fields declare the keys.
    """

    path: str
    doc: str
    keys: tuple[Key, ...]
    children: tuple[str, ...] = ()
    cls: type | None = field(default=None, compare=False, repr=False)

    def dotted(self, name: str) -> str:
        return f"{self.path}.{name}" if self.path else name

    def read(self, table: Any, source: str, **extra: Any) -> Any:
        """Validate ``table`` and build ``cls`` from its SI values (and ``extra`` fields)."""
        assert self.cls is not None, f"section [{self.path}] has no dataclass"
        return self.cls(**read_section(table, self, source), **extra)


def section_of(cls: type, path: str, doc: str, children: tuple[str, ...] = ()) -> Section:
    """The section of TOML table ``path`` whose keys are the setting fields of ``cls``."""
    return Section(path, doc, keys_of(cls), children, cls)


def _num(x: float) -> str:
    return f"{x:g}"


def check_unknown(table: Mapping[str, Any], allowed: Sequence[str], where: str,
                  source: str) -> None:
    """Refuse keys that are not in ``allowed``, suggesting the closest allowed name."""
    for name in table:
        if name in allowed:
            continue
        dotted = f"{where}.{name}" if where else name
        close = difflib.get_close_matches(name, list(allowed), n=1, cutoff=0.6)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        scope = f"[{where}]" if where else "the top level"
        raise SceneError(source, f"unknown key '{dotted}'{hint} "
                                 f"(keys allowed in {scope}: {', '.join(allowed)})")


def read_section(table: Any, section: Section, source: str) -> dict[str, Any]:
    """Validate one table against its section and return ``{attr: SI value}`` for its own keys.

    Sub-tables named in ``section.children`` are left to the caller.
    """
    if table is None:
        table = {}
    if not isinstance(table, Mapping):
        raise SceneError(source, "must be a table ([" + section.path + "])", key=section.path,
                         value=table)
    check_unknown(table, [k.name for k in section.keys] + list(section.children), section.path,
                  source)
    for child in section.children:
        if child in table and not isinstance(table[child], Mapping):
            raise SceneError(source, "must be a table", key=section.dotted(child),
                             value=table[child])
    out: dict[str, Any] = {}
    for key in section.keys:
        dotted = section.dotted(key.name)
        if key.name not in table:
            if key.default is REQUIRED:
                meaning = key.doc.split(".")[0]
                raise SceneError(source, f"missing required key '{dotted}' ({meaning}; "
                                         f"{key.allowed()})")
            out[key.attr] = None if key.default is None else _convert(key, key.default, dotted,
                                                                      source)
        else:
            out[key.attr] = _convert(key, table[key.name], dotted, source)
    return out


def _convert(key: Key, value: Any, dotted: str, source: str) -> Any:
    t = key.type
    if t == "float":
        return _number(key, value, dotted, source) * key.scale
    if t == "floats":
        if not isinstance(value, list) or not value:
            raise SceneError(source, "expected " + key.allowed(), key=dotted, value=value)
        return tuple(_number(key, v, f"{dotted}[{i}]", source) * key.scale
                     for i, v in enumerate(value))
    if t == "int":
        if isinstance(value, bool) or not isinstance(value, int):
            raise SceneError(source, f"expected an integer, got {_kind(value)}", key=dotted,
                             value=value, allowed=key.allowed())
        if not key.in_range(value):
            raise SceneError(source, "out of range", key=dotted, value=value, allowed=key.allowed())
        return value
    if t == "str":
        if not isinstance(value, str):
            raise SceneError(source, f"expected a string, got {_kind(value)}", key=dotted,
                             value=value, allowed=key.allowed())
        if key.choices and value not in key.choices:
            close = difflib.get_close_matches(value, key.choices, n=1, cutoff=0.5)
            hint = f"; did you mean \"{close[0]}\"?" if close else ""
            raise SceneError(source, f"not a known choice{hint}", key=dotted, value=value,
                             allowed=key.allowed())
        return value
    if t == "bool":
        if not isinstance(value, bool):
            raise SceneError(source, f"expected true or false, got {_kind(value)}", key=dotted,
                             value=value)
        return value
    raise AssertionError(f"unknown key type {t!r}")  # a schema bug, not user input


def _number(key: Key, value: Any, dotted: str, source: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SceneError(source, f"expected a number, got {_kind(value)}", key=dotted,
                         value=value, allowed=key.allowed())
    v = float(value)
    if not math.isfinite(v):
        raise SceneError(source, "must be a finite number", key=dotted, value=value,
                         allowed=key.allowed())
    if not key.in_range(v):
        raise SceneError(source, "out of range", key=dotted, value=value, allowed=key.allowed())
    return v


_KIND_WORDS = ((bool, "a boolean"), (str, "a string"), (int, "an integer"), (float, "a number"),
               (list, "a list"), (Mapping, "a table"),
               ((datetime.date, datetime.time), "a date or time"))


def _kind(value: Any) -> str:
    """What a TOML value is, in words (bool before int: a TOML boolean is a Python int)."""
    for t, word in _KIND_WORDS:
        if isinstance(value, t):
            return word
    return type(value).__name__


def keys_reference(sections: Sequence[Section], title: str, preamble: str) -> str:
    """Markdown reference of every key (the content of docs/scenes.md)."""
    lines = [f"# {title}", "", preamble.strip(), ""]
    for s in sections:
        lines += [f"## `[{s.path}]`", "", s.doc.strip(), "",
                  "| key | unit | default | allowed | meaning |", "|---|---|---|---|---|"]
        for k in s.keys:
            if k.default is REQUIRED:
                default = "**required**"
            elif k.default is None:
                default = "—"
            else:
                default = f"`{format_value(k.default)}`"
            doc = k.doc.replace("|", "\\|")
            lines.append(f"| `{k.name}` | {k.unit or '—'} | {default} | {k.allowed()} | {doc} |")
        lines.append("")
    return "\n".join(lines)
