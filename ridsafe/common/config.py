"""Configuration: YAML documents loaded into frozen dataclasses, driven by their type hints.

A configuration class is an ordinary (frozen) dataclass; its type hints are the schema::

    @dataclass(frozen=True)
    class SimConfig:
        physics_hz: int = 400
        controller_hz: int = 100
        origin: GeodeticOrigin = GeodeticOrigin(47.0, 8.0, 400.0)

        def __post_init__(self) -> None:
            if self.physics_hz % self.controller_hz:
                raise FieldValueError("physics_hz", "must be a multiple of controller_hz")

    cfg = load_config("configs/default.yaml", ScenarioConfig)
    cfg = with_overrides(cfg, {"sim.physics_hz": 200})

Supported field types: nested dataclasses, ``int``, ``float`` (ints accepted; NaN and inf
rejected), ``bool``, ``str``, ``pathlib.Path``, ``Literal[...]``, ``enum.Enum`` subclasses (by
value or by name), ``tuple[X, Y, Z]`` (fixed length) and ``tuple[X, ...]`` (from YAML lists),
``X | None`` (and other unions, tried left to right) and ``dict[str, X]``. A ``bool`` is never
accepted as a number, nor a float as an int. Missing keys take the dataclass default; missing keys
without one, and unknown keys, are errors. ``from __future__ import annotations`` is fine: hints
are resolved with :func:`typing.get_type_hints`.

Every problem raises :class:`~ridsafe.common.errors.ConfigError` naming the file and key path::

    configs/default.yaml: sim.physics_hz: expected int, got str 'fast'
    configs/default.yaml: sim.phisics_hz: unknown key (known: physics_hz, controller_hz, origin)
    configs/paper.yaml: gcs.imm.transition[1]: row sums to 0.97, must be 1
    configs/default.yaml: line 4, column 9: YAML syntax error: mapping values are not allowed here

A ``ValueError`` raised by a dataclass's ``__post_init__`` is reported at that dataclass's key
path; a :class:`~ridsafe.common.errors.FieldValueError` is reported at the path of the field it
names. The YAML reader is PyYAML's safe loader with two fixes: duplicate keys are errors (PyYAML
silently keeps the last), and ``1e-3`` is a float (YAML 1.1 reads it as a string). YAML 1.1 still
reads unquoted ``yes``/``no``/``on``/``off`` as booleans: quote them where a string is meant.
"""

from __future__ import annotations

import dataclasses
import difflib
import enum
import functools
import math
import numbers
import re
import types
import typing
from collections.abc import Callable, Hashable, Mapping
from pathlib import Path
from typing import Any, TypeAlias, TypeVar, cast

import yaml

from ridsafe.common.errors import ConfigError, FieldValueError

__all__ = [
    "OVERRIDE_SOURCE",
    "from_mapping",
    "load_config",
    "parse_override",
    "parse_yaml",
    "to_mapping",
    "with_overrides",
]

T = TypeVar("T")

#: The ``source`` named in errors about command-line overrides.
OVERRIDE_SOURCE = "override"

_MAX_REPR = 60

# (annotation, value, key path, source) -> converted value
_Converter = Callable[[Any, object, str, str], object]


# --------------------------------------------------------------------------------------------
# YAML reading


_MERGE_TAG = "tag:yaml.org,2002:merge"


#: libyaml's parser when PyYAML was built with it (about 10x faster), else the pure-Python one.
_SafeLoaderBase: type[yaml.SafeLoader] = getattr(yaml, "CSafeLoader", yaml.SafeLoader)
#: Larger configuration texts are refused before parsing (the project's are a few kB).
MAX_CONFIG_BYTES = 1 << 20


class _StrictLoader(_SafeLoaderBase):  # type: ignore[valid-type,misc]
    """PyYAML's safe loader (libyaml's parser where available), rejecting duplicate keys and
    reading ``1e-3`` as a float."""

    def construct_mapping(self, node: yaml.MappingNode, deep: bool = False) -> dict[Any, Any]:
        seen: set[object] = set()
        for key_node, _ in node.value:
            if key_node.tag == _MERGE_TAG:  # "<<: *anchor" may be overridden by explicit keys
                continue
            key = self.construct_object(key_node, deep=True)
            if isinstance(key, Hashable) and key in seen:
                raise yaml.constructor.ConstructorError(
                    None, None, f"duplicate key {key!r}", key_node.start_mark
                )
            seen.add(key)
        mapping: dict[Any, Any] = super().construct_mapping(node, deep=deep)
        return mapping


# YAML 1.2 floats without a decimal point, e.g. 1e-3, -2E+6 (YAML 1.1 reads them as strings).
_StrictLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(r"^[-+]?[0-9][0-9_]*[eE][-+]?[0-9]+$"),
    list("-+0123456789"),
)


def parse_yaml(text: str, source: str) -> object:
    """Parse one YAML document with the strict loader; syntax errors name ``source`` and line.
    A text over ``MAX_CONFIG_BYTES`` is refused unparsed."""
    size = len(text.encode("utf-8"))
    if size > MAX_CONFIG_BYTES:
        raise ConfigError(
            source, "", f"configuration is {size} bytes, more than the {MAX_CONFIG_BYTES} allowed"
        )
    try:
        return yaml.load(text, Loader=_StrictLoader)
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        where = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        problem = err.problem or err.context or "malformed YAML"
        raise ConfigError(source, "", f"{where}YAML syntax error: {problem}") from err
    except yaml.YAMLError as err:
        raise ConfigError(source, "", f"YAML error: {err}") from err


# --------------------------------------------------------------------------------------------
# Public entry points


def load_config(path: str | Path, cls: type[T]) -> T:
    """Read the YAML file at ``path`` and build a ``cls`` from it (see the module docstring)."""
    source = str(path)
    try:
        size = Path(path).stat().st_size
        if size > MAX_CONFIG_BYTES:
            raise ConfigError(
                source,
                "",
                f"configuration file is {size} bytes, more than the {MAX_CONFIG_BYTES} allowed",
            )
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(source, "", f"cannot read configuration file: {err}") from err
    return from_mapping(cls, parse_yaml(text, source), source)


def from_mapping(cls: type[T], data: object, source: str) -> T:
    """Build the dataclass ``cls`` from plain data (as parsed from YAML).

    ``source`` names the origin of ``data`` (a file name) in error messages.
    """
    if not (isinstance(cls, type) and dataclasses.is_dataclass(cls)):
        raise TypeError(f"from_mapping: expected a dataclass type, got {cls!r}")
    return cast(T, _convert_dataclass(cls, data, "", source))


def with_overrides(cfg: T, overrides: Mapping[str, object], source: str = OVERRIDE_SOURCE) -> T:
    """Return ``cfg`` with dotted-key overrides applied: ``{"sim.physics_hz": 200}``.

    Values are converted and validated exactly as if they came from YAML; every dataclass on a
    changed path is rebuilt once with :func:`dataclasses.replace` (so its ``__post_init__`` sees
    all overrides together). Keys into a ``dict[str, X]`` field may name an entry
    (``"radios.rx1.gain_db"``). Unknown keys are rejected.
    """
    if not dataclasses.is_dataclass(cfg) or isinstance(cfg, type):
        raise TypeError(f"with_overrides: expected a dataclass instance, got {cfg!r}")
    tree = _override_tree(overrides, source)
    return cast(T, _apply_tree(type(cfg), cfg, tree, "", source))


def parse_override(text: str, source: str = OVERRIDE_SOURCE) -> tuple[str, object]:
    """Split a command-line override ``"sim.speed=5.0"`` into ``("sim.speed", 5.0)``.

    The value is read as a YAML scalar or flow collection (``5``, ``true``, ``fast``,
    ``[1, 2, 3]``); an empty value is ``None``.
    """
    key, sep, raw = text.partition("=")
    key = key.strip()
    if not sep or not key:
        raise ConfigError(source, "", f"expected KEY=VALUE, got {text!r}")
    return key, parse_yaml(raw, f"{source} {key}")


def to_mapping(cfg: object) -> dict[str, object]:
    """The plain-data form of a config dataclass (enums by value, tuples as lists).

    ``from_mapping(type(cfg), to_mapping(cfg), ...) == cfg``; suited to ``yaml.safe_dump`` and to
    recording a run's configuration in its log.
    """
    if not dataclasses.is_dataclass(cfg) or isinstance(cfg, type):
        raise TypeError(f"to_mapping: expected a dataclass instance, got {cfg!r}")
    return {f.name: _plain(getattr(cfg, f.name)) for f in dataclasses.fields(cfg) if f.init}


def _plain(value: object) -> object:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return to_mapping(value)
    if isinstance(value, enum.Enum):
        return value.value
    if isinstance(value, tuple | list):
        return [_plain(v) for v in value]
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, Path):
        return str(value)
    return value


# --------------------------------------------------------------------------------------------
# Messages and paths


def _join(path: str, key: str) -> str:
    return f"{path}.{key}" if path else key


_KIND_NAMES: dict[type, str] = {dict: "mapping", list: "list"}


def _describe(value: object) -> str:
    """``str 'fast'``, ``bool True``, ``null``, ``mapping {...}``: what came, for messages."""
    if value is None:
        return "null"
    kind = _KIND_NAMES.get(type(value), type(value).__name__)
    text = repr(value)
    if len(text) > _MAX_REPR:
        text = text[: _MAX_REPR - 3] + "..."
    return f"{kind} {text}"


def _type_name(tp: object) -> str:
    if tp is type(None):
        return "null"
    if isinstance(tp, type) and typing.get_origin(tp) is None:
        return tp.__name__
    return str(tp).replace("typing.", "")


def _expected(tp: object, value: object, path: str, source: str) -> ConfigError:
    return ConfigError(source, path, f"expected {_type_name(tp)}, got {_describe(value)}")


# --------------------------------------------------------------------------------------------
# Dataclasses


@functools.cache
def _init_fields(cls: type) -> dict[str, dataclasses.Field[Any]]:
    return {f.name: f for f in dataclasses.fields(cls) if f.init}


@functools.cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _unknown_key(key: object, known: Mapping[str, object], path: str, source: str) -> ConfigError:
    names = list(known)
    reason = f"unknown key (known: {', '.join(names)})"
    close = difflib.get_close_matches(str(key), names, n=1)
    if close:
        reason += f"; did you mean {close[0]}?"
    return ConfigError(source, _join(path, str(key)), reason)


def _has_default(field: dataclasses.Field[Any]) -> bool:
    return (
        field.default is not dataclasses.MISSING or field.default_factory is not dataclasses.MISSING
    )


def _convert_dataclass(cls: type, value: object, path: str, source: str) -> object:
    if isinstance(value, cls):
        return value
    if not isinstance(value, Mapping):
        raise ConfigError(
            source, path, f"expected mapping ({cls.__name__}), got {_describe(value)}"
        )
    fields = _init_fields(cls)
    hints = _hints(cls)
    for key in value:
        if key not in fields:
            raise _unknown_key(key, fields, path, source)
    kwargs: dict[str, object] = {}
    for name, field in fields.items():
        if name in value:
            kwargs[name] = _convert(hints[name], value[name], _join(path, name), source)
        elif not _has_default(field):
            raise ConfigError(
                source,
                _join(path, name),
                f"missing required key (expected {_type_name(hints[name])})",
            )
    return _build(lambda: cls(**kwargs), path, source)


def _build(make: Callable[[], object], path: str, source: str) -> object:
    """Run a dataclass constructor, turning its validation errors into ConfigErrors at ``path``."""
    try:
        return make()
    except FieldValueError as err:
        raise ConfigError(source, _join(path, err.field), err.reason) from err
    except ConfigError:
        raise
    except ValueError as err:
        raise ConfigError(source, path, str(err)) from err


# --------------------------------------------------------------------------------------------
# Conversions, one per kind of annotation


def _convert(tp: object, value: object, path: str, source: str) -> object:
    return _converter_for(tp)(tp, value, path, source)


def _converter_for(tp: object) -> _Converter:
    origin = typing.get_origin(tp)
    handler: _Converter | None = None
    if origin is not None:
        handler = _GENERIC_CONVERTERS.get(origin)
    elif isinstance(tp, type):
        if dataclasses.is_dataclass(tp):
            handler = _convert_dataclass
        elif issubclass(tp, enum.Enum):
            handler = _convert_enum
        else:
            handler = _SCALAR_CONVERTERS.get(tp)
    if handler is None:
        raise TypeError(f"config: unsupported field annotation {tp!r}")
    return handler


def _convert_int(tp: object, value: object, path: str, source: str) -> object:
    if isinstance(value, bool):  # bool is an int in Python, never in a config
        raise _expected(tp, value, path, source)
    if isinstance(value, numbers.Integral):
        return int(value)
    raise _expected(tp, value, path, source)


def _convert_float(tp: object, value: object, path: str, source: str) -> object:
    if isinstance(value, bool):
        raise _expected(tp, value, path, source)
    if isinstance(value, numbers.Real):
        number = float(value)
        if not math.isfinite(number):
            raise ConfigError(source, path, f"expected a finite float, got {number!r}")
        return number
    raise _expected(tp, value, path, source)


def _convert_exact(tp: object, value: object, path: str, source: str) -> object:
    """``bool`` and ``str``: only the type itself."""
    if type(value) is tp:
        return value
    raise _expected(tp, value, path, source)


def _convert_path(tp: object, value: object, path: str, source: str) -> object:
    if isinstance(value, Path):
        return value
    if isinstance(value, str) and value:
        return Path(value)
    raise ConfigError(source, path, f"expected a path (non-empty str), got {_describe(value)}")


def _convert_enum(tp: type[enum.Enum], value: object, path: str, source: str) -> object:
    if isinstance(value, tp):
        return value
    for member in tp:
        if type(member.value) is type(value) and member.value == value:
            return member
    if isinstance(value, str) and value in tp.__members__:
        return tp[value]
    options = ", ".join(f"{m.name}={m.value!r}" for m in tp)
    raise ConfigError(source, path, f"expected a {tp.__name__} ({options}), got {_describe(value)}")


def _convert_literal(tp: object, value: object, path: str, source: str) -> object:
    options = typing.get_args(tp)
    for option in options:
        if type(option) is type(value) and option == value:
            return option
    listed = ", ".join(repr(o) for o in options)
    raise ConfigError(source, path, f"expected one of {listed}, got {_describe(value)}")


def _convert_union(tp: object, value: object, path: str, source: str) -> object:
    arms = typing.get_args(tp)
    if value is None and type(None) in arms:
        return None
    candidates = [arm for arm in arms if arm is not type(None)]
    if len(candidates) == 1:
        return _convert(candidates[0], value, path, source)
    errors: list[ConfigError] = []
    for arm in candidates:
        try:
            return _convert(arm, value, path, source)
        except ConfigError as err:
            errors.append(err)
    deeper = [e for e in errors if e.key_path != path]
    if len(deeper) == 1:  # only one arm got past the top level: its complaint is the useful one
        raise deeper[0]
    raise _expected(tp, value, path, source)


def _convert_tuple(tp: object, value: object, path: str, source: str) -> object:
    args = typing.get_args(tp)
    if not isinstance(value, list | tuple):
        raise ConfigError(source, path, f"expected list ({_type_name(tp)}), got {_describe(value)}")
    if len(args) == 2 and args[1] is Ellipsis:
        item_types = [args[0]] * len(value)
    elif len(value) != len(args):
        reason = f"expected {len(args)} items ({_type_name(tp)}), got {len(value)}"
        raise ConfigError(source, path, reason)
    else:
        item_types = list(args)
    return tuple(
        _convert(item_tp, item, f"{path}[{i}]", source)
        for i, (item_tp, item) in enumerate(zip(item_types, value, strict=True))
    )


def _convert_dict(tp: object, value: object, path: str, source: str) -> object:
    key_tp, value_tp = typing.get_args(tp)
    if key_tp is not str:
        raise TypeError(f"config: only dict[str, X] is supported, got {tp!r}")
    if not isinstance(value, Mapping):
        raise _expected(tp, value, path, source)
    result: dict[str, object] = {}
    for key, item in value.items():
        if not isinstance(key, str):
            raise ConfigError(source, path, f"expected str keys, got {_describe(key)}")
        result[key] = _convert(value_tp, item, _join(path, key), source)
    return result


_SCALAR_CONVERTERS: dict[object, _Converter] = {
    int: _convert_int,
    float: _convert_float,
    bool: _convert_exact,
    str: _convert_exact,
    Path: _convert_path,
}

_GENERIC_CONVERTERS: dict[object, _Converter] = {
    typing.Literal: _convert_literal,
    typing.Union: _convert_union,
    types.UnionType: _convert_union,
    tuple: _convert_tuple,
    dict: _convert_dict,
    Mapping: _convert_dict,
}


# --------------------------------------------------------------------------------------------
# Overrides


@dataclasses.dataclass(frozen=True)
class _Leaf:
    """A value to set, at the end of a dotted override key."""

    value: object


_Tree: TypeAlias = "dict[str, _Leaf | _Tree]"


def _override_tree(overrides: Mapping[str, object], source: str) -> _Tree:
    """``{"a.b": 1, "a.c": 2}`` -> ``{"a": {"b": _Leaf(1), "c": _Leaf(2)}}``."""
    tree: _Tree = {}
    for dotted, value in overrides.items():
        parts = dotted.split(".")
        if not all(parts) or any(c in dotted for c in "[] "):
            raise ConfigError(source, dotted, "malformed override key (expected a.b.c)")
        node = tree
        for depth, part in enumerate(parts[:-1]):
            child = node.setdefault(part, {})
            if isinstance(child, _Leaf):
                prefix = ".".join(parts[: depth + 1])
                raise ConfigError(source, dotted, f"conflicts with the override of {prefix}")
            node = child
        if parts[-1] in node:  # "a.b.c" came first, now "a.b"
            raise ConfigError(source, dotted, "conflicts with overrides of keys inside it")
        node[parts[-1]] = _Leaf(value)
    return tree


def _apply_tree(tp: object, obj: object, tree: _Tree, path: str, source: str) -> object:
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return _apply_to_dataclass(obj, tree, path, source)
    dict_tp = _dict_annotation(tp)
    if isinstance(obj, dict) and dict_tp is not None:
        return _apply_to_dict(dict_tp, obj, tree, path, source)
    reason = f"cannot set keys inside {_describe(obj)}; override the whole value instead"
    raise ConfigError(source, _join(path, next(iter(tree))), reason)


def _apply_to_dataclass(obj: Any, tree: _Tree, path: str, source: str) -> object:
    cls: type = type(obj)
    fields = _init_fields(cls)
    hints = _hints(cls)
    changes: dict[str, object] = {}
    for name, sub in tree.items():
        if name not in fields:
            raise _unknown_key(name, fields, path, source)
        sub_path = _join(path, name)
        if isinstance(sub, _Leaf):
            changes[name] = _convert(hints[name], sub.value, sub_path, source)
        else:
            changes[name] = _apply_tree(hints[name], getattr(obj, name), sub, sub_path, source)
    return _build(lambda: dataclasses.replace(obj, **changes), path, source)


def _apply_to_dict(
    tp: object, obj: dict[str, object], tree: _Tree, path: str, source: str
) -> object:
    value_tp = typing.get_args(tp)[1]
    result = dict(obj)
    for key, sub in tree.items():
        sub_path = _join(path, key)
        if isinstance(sub, _Leaf):
            result[key] = _convert(value_tp, sub.value, sub_path, source)
        elif key in obj:
            result[key] = _apply_tree(value_tp, obj[key], sub, sub_path, source)
        else:
            raise _unknown_key(key, obj, path, source)
    return result


def _dict_annotation(tp: object) -> object | None:
    """``dict[str, X]`` itself, or the dict arm of ``dict[str, X] | None``."""
    origin = typing.get_origin(tp)
    if origin in (dict, Mapping):
        return tp
    if origin in (typing.Union, types.UnionType):
        arm: object
        for arm in typing.get_args(tp):
            if typing.get_origin(arm) in (dict, Mapping):
                return arm
    return None
