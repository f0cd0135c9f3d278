"""The dataclasses are the schema: every scene key is declared once, as a dataclass field whose
metadata carries the key and whose default is the key's file default in SI; the sections of the
file (and so the reading and docs/scenes.md) are derived from the classes."""

# setting(...) returns a dataclasses.field (a default and metadata), not a shared value

from __future__ import annotations

import dataclasses
import inspect
import math
from dataclasses import MISSING, dataclass, fields

import pytest

import micropit_hpc.scene as scene_module
from micropit_hpc.errors import SceneError
from micropit_hpc.scene import SECTIONS, GearSpec, GearTable, Scene, StudyTable
from micropit_hpc.schema import (
    KEY,
    REQUIRED,
    Key,
    Section,
    keys_of,
    read_section,
    section_of,
    setting,
)

_ANNOTATION = {"float": "float", "int": "int", "str": "str", "bool": "bool",
               "floats": "tuple[float, ...]"}


def _keyed(cls: type) -> list[dataclasses.Field]:
    return [f for f in fields(cls) if KEY in f.metadata]


def _setting_classes() -> list[type]:
    """Every dataclass of the scene module that declares at least one key."""
    return [c for _, c in inspect.getmembers(scene_module, inspect.isclass)
            if dataclasses.is_dataclass(c) and c.__module__ == scene_module.__name__ and _keyed(c)]


def _si(key: Key):
    """A file default converted to SI, as a value given in the file is."""
    if key.type == "float":
        return float(key.default) * key.scale
    if key.type == "floats":
        return tuple(float(v) * key.scale for v in key.default)
    return key.default


def _same(a, b) -> bool:
    """Equal and of the same type, floats bit for bit."""
    if isinstance(a, tuple) and isinstance(b, tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and isinstance(b, float):
        return a.hex() == b.hex()
    return type(a) is type(b) and a == b


@pytest.mark.parametrize("section", SECTIONS, ids=lambda s: s.path)
def test_sections_are_derived_from_their_dataclass(section):
    """A section's keys are exactly the keyed fields of its class, in field order."""
    assert section.cls is not None
    assert section.keys == keys_of(section.cls)
    assert [k.attr for k in section.keys] == [f.name for f in _keyed(section.cls)]
    for key, f in zip(section.keys, _keyed(section.cls), strict=True):
        assert key == dataclasses.replace(f.metadata[KEY], attr=f.name)


def test_every_declared_key_is_read_in_a_section():
    """Each class with key fields is the class of a section of the file: no setting is declared
    that the file cannot give."""
    read = {s.cls for s in SECTIONS}
    classes = _setting_classes()
    assert classes and set(classes) <= read
    # and the objects the rest of the code uses are among them
    for cls in (scene_module.WindowSpec, scene_module.LubricationSpec, scene_module.LifeSpec,
                scene_module.SurfaceSpec, scene_module.Body, scene_module.Lubricant):
        assert cls in read


@pytest.mark.parametrize("cls", _setting_classes(), ids=lambda c: c.__name__)
def test_dataclass_default_is_the_converted_file_default(cls):
    for f in _keyed(cls):
        key = f.metadata[KEY]
        assert key.attr == "", "attr comes from the field's name, not from the declaration"
        if key.default is REQUIRED:
            assert f.default is MISSING and f.default_factory is MISSING and f.kw_only, f.name
        elif key.default is None:
            assert f.default is None, f.name
        else:
            assert _same(f.default, _si(key)), (f.name, f.default, _si(key))


@pytest.mark.parametrize("cls", _setting_classes(), ids=lambda c: c.__name__)
def test_annotation_agrees_with_the_key_type(cls):
    for f in _keyed(cls):
        key = f.metadata[KEY]
        wanted = _ANNOTATION[key.type]
        if key.default is None:
            wanted += " | None"
        assert f.type == wanted, (cls.__name__, f.name, f.type, wanted)


def test_fields_that_are_not_keys_carry_no_key():
    non_keys = {scene_module.Lubricant: {"derived"}, scene_module.Body: {"surface"},
                GearSpec: {f.name for f in fields(GearSpec)},
                scene_module.PositionSpec: {"kind", "values", "count"},
                scene_module.DiscSpec: {f.name for f in fields(scene_module.DiscSpec)},
                Scene: {f.name for f in fields(Scene)}}
    for cls, names in non_keys.items():
        assert names == {f.name for f in fields(cls) if KEY not in f.metadata}, cls.__name__


def test_derived_objects_take_their_defaults_from_the_tables():
    """GearSpec and Scene repeat no default: theirs are the table classes' (SI) defaults."""
    for name in ("slide_roll_imposed", "pitch_snap", "material_factor_ww"):
        assert _same(GearSpec.__dataclass_fields__[name].default,
                     GearTable.__dataclass_fields__[name].default)
    for name in ("roughness_scale", "patches"):
        assert _same(Scene.__dataclass_fields__[name].default,
                     StudyTable.__dataclass_fields__[name].default)


def test_no_free_standing_keys():
    """A key cannot be declared outside a dataclass field: the scene module makes no Key and
    holds none, bare or in a container, outside its sections."""
    source = inspect.getsource(scene_module)
    assert "Key(" not in source and "Section(" not in source
    for name, value in vars(scene_module).items():
        assert not isinstance(value, Key), name
        if isinstance(value, tuple | list) and not name == "SECTIONS":
            assert not any(isinstance(v, Key | Section) for v in value), name
        if isinstance(value, Section):
            assert value in SECTIONS, name


def test_omitted_keys_read_as_the_dataclass_defaults():
    """Reading an empty table gives the dataclass defaults, float for float."""
    for section in SECTIONS:
        if any(k.default is REQUIRED for k in section.keys):
            continue
        built = section.read({}, "<test>")
        default = section.cls()
        for f in fields(section.cls):
            assert _same(getattr(built, f.name), getattr(default, f.name)), (section.path,
                                                                             f.name)


# --- the generic machinery, on a toy class ----------------------------------------------------
@dataclass(frozen=True)
class _Toy:
    length: float = setting("length_mm", "float", "A length.", "mm", 1e-3, lo=0, lo_open=True)
    width: float = setting("width_mm", "float", "A width.", "mm", 1e-3, default=300.0, lo=0)
    sizes: tuple[float, ...] = setting("sizes_um", "floats", "Sizes.", "µm", 1e-6,
                                       default=[1.0, 2.5])
    mode: str = setting("mode", "str", "A choice.", default="a", choices=("a", "b"))
    note: str | None = None


def test_setting_and_section_of_on_a_toy_class():
    section = section_of(_Toy, "toy", "A toy table.")
    assert [k.name for k in section.keys] == ["length_mm", "width_mm", "sizes_um", "mode"]
    assert [k.attr for k in section.keys] == ["length", "width", "sizes", "mode"]
    assert _same(_Toy.__dataclass_fields__["width"].default, 300.0 * 1e-3)
    assert _same(_Toy.__dataclass_fields__["sizes"].default, (1.0e-6, 2.5 * 1e-6))
    toy = section.read({"length_mm": 2}, "<toy>")
    assert toy == _Toy(length=2.0 * 1e-3)
    assert read_section({"length_mm": 2}, section, "<toy>") == {
        "length": 2.0 * 1e-3, "width": 300.0 * 1e-3, "sizes": (1.0e-6, 2.5 * 1e-6), "mode": "a"}
    with pytest.raises(TypeError):
        _Toy(2e-3)  # a required setting is keyword-only
    with pytest.raises(SceneError, match="missing required key 'toy.length_mm'"):
        section.read({}, "<toy>")


def test_a_default_outside_its_range_is_refused_at_declaration():
    with pytest.raises(SceneError, match="out of range"):
        setting("bad", "float", "A bad default.", default=-1.0, lo=0)
    with pytest.raises(SceneError, match="not a known choice"):
        setting("bad", "str", "A bad default.", default="c", choices=("a", "b"))
    assert math.isclose(setting("ok", "float", "Fine.", "mm", 1e-3, default=1.0).default, 1e-3)
