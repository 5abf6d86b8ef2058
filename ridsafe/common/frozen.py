"""A cheaper ``__init__`` for the frozen dataclasses built on every message.

A frozen dataclass's generated ``__init__`` stores each field through
``object.__setattr__`` (its own ``__setattr__`` refuses); that costs about 0.1 us a field
and a lockstep run builds some 800,000 such objects (received packets, RSSI reports,
observations, neighbour claims). :func:`quick_init` swaps in an ``__init__`` with the same
signature that writes the fields straight into the instance (its ``__dict__``, or the
slot descriptors of a ``slots=True`` class), about twice as fast. Everything else stays
the dataclass's: frozen assignment still raises ``FrozenInstanceError``, and ``==``,
``hash``, ``repr``, ``replace`` and pickling are untouched.

Only plain classes qualify: every field in ``__init__`` (``init=True``), no
``default_factory``, ``InitVar`` or ``__post_init__``, which would need the generated code; any
other class is refused with a ``TypeError`` rather than silently given the wrong
``__init__``.
"""

from __future__ import annotations

import dataclasses
import inspect
from typing import Any, TypeVar

__all__ = ["quick_init"]

T = TypeVar("T")

_SELF = "_quick_init_self"
_STORE = "_quick_init_store"


def quick_init(cls: type[T]) -> type[T]:
    """Give the frozen dataclass ``cls`` the fast ``__init__`` (see the module docstring);
    apply it above ``@dataclass(frozen=True, ...)``."""
    params = getattr(cls, "__dataclass_params__", None)
    if params is None or not params.frozen or not params.init:
        raise TypeError(f"{cls.__qualname__}: quick_init needs a frozen dataclass with __init__")
    if hasattr(cls, "__post_init__"):
        raise TypeError(f"{cls.__qualname__}: quick_init cannot run __post_init__")
    fields = dataclasses.fields(cls)  # type: ignore[arg-type]
    if len(inspect.signature(cls.__init__).parameters) != len(fields) + 1:  # InitVar ones
        raise TypeError(f"{cls.__qualname__}: quick_init takes no InitVar pseudo-fields")
    for f in fields:
        if not f.init or f.default_factory is not dataclasses.MISSING:
            raise TypeError(f"{cls.__qualname__}.{f.name}: quick_init needs init=True, no factory")
    namespace: dict[str, Any] = {}
    positional: list[str] = []
    keyword: list[str] = []
    for f in fields:
        parameter = f.name
        if f.default is not dataclasses.MISSING:
            namespace[f"_default_{f.name}"] = f.default
            parameter += f"=_default_{f.name}"
        (keyword if f.kw_only else positional).append(parameter)
    parameters = [_SELF, *positional, *(["*", *keyword] if keyword else [])]
    if "__slots__" in cls.__dict__:
        for f in fields:
            namespace[f"_set_{f.name}"] = cls.__dict__[f.name].__set__
        body = [f"_set_{f.name}({_SELF}, {f.name})" for f in fields]
    else:
        body = [f"{_STORE} = {_SELF}.__dict__"]
        body += [f"{_STORE}[{f.name!r}] = {f.name}" for f in fields]
    source = f"def __init__({', '.join(parameters)}) -> None:\n"
    source += "".join(f"    {line}\n" for line in body or ["pass"])
    exec(source, namespace)
    init = namespace["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"
    init.__module__ = cls.__module__
    init.__doc__ = cls.__init__.__doc__
    cls.__init__ = init  # type: ignore[method-assign]
    return cls
