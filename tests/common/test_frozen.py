"""quick_init: the same frozen dataclass, built faster; anything it cannot do is refused."""

from __future__ import annotations

import dataclasses
import inspect
import pickle
from dataclasses import InitVar, dataclass, field
from typing import Any, ClassVar

import pytest

from ridsafe.common.frozen import quick_init


def twins(slots: bool) -> tuple[type[Any], type[Any]]:
    """The same class twice: with the dataclass's __init__ and with quick_init's."""

    def make() -> type[Any]:
        class Reading:
            KIND: ClassVar[str] = "reading"
            sysid: int
            rssi_dbm: float
            label: str = "rx"
            tags: tuple[str, ...] = ()
            _: dataclasses.KW_ONLY
            signed: bool = False
            source: object = None

        if slots:
            return dataclass(frozen=True, slots=True)(Reading)
        return dataclass(frozen=True)(Reading)

    return make(), quick_init(make())


CALLS = [
    ((1, -70.5), {}),
    ((2, -80.0, "b"), {"signed": True}),
    ((3,), {"rssi_dbm": -60.0, "tags": ("x",), "source": (1,)}),
    ((), {"sysid": 4, "rssi_dbm": 1.0, "label": "c", "tags": (), "signed": True}),
]


@pytest.mark.parametrize("slots", [False, True])
@pytest.mark.parametrize(("args", "kwargs"), CALLS)
def test_builds_what_the_dataclass_builds(
    slots: bool, args: tuple[Any, ...], kwargs: dict[str, Any]
) -> None:
    stock, quick = twins(slots)
    assert "_quick_init_self" in quick.__init__.__code__.co_varnames  # the swapped-in one
    a, b = stock(*args, **kwargs), quick(*args, **kwargs)
    assert dataclasses.asdict(a) == dataclasses.asdict(b)
    assert repr(a) == repr(b)
    other = quick(*args, **kwargs)
    assert b == other and hash(b) == hash(other)
    assert dataclasses.replace(b, sysid=9).sysid == 9
    with pytest.raises(dataclasses.FrozenInstanceError):
        b.sysid = 5
    with pytest.raises(dataclasses.FrozenInstanceError):
        del b.rssi_dbm


@pytest.mark.parametrize("slots", [False, True])
def test_wrong_calls_fail_as_they_would(slots: bool) -> None:
    _, quick = twins(slots)
    with pytest.raises(TypeError, match="rssi_dbm"):
        quick(1)
    with pytest.raises(TypeError, match="unexpected keyword"):
        quick(1, 2.0, colour="red")
    with pytest.raises(TypeError, match="positional"):
        quick(1, 2.0, "a", (), True)  # signed is keyword-only


@quick_init
@dataclass(frozen=True, slots=True)
class Module:
    sysid: int
    position_m: tuple[float, float] = (0.0, 0.0)


def test_module_level_classes_pickle_and_keep_their_signature() -> None:
    value = Module(3, (1.0, 2.0))
    assert pickle.loads(pickle.dumps(value)) == value
    assert Module.__init__.__qualname__ == "Module.__init__"
    parameters = list(inspect.signature(Module.__init__).parameters.values())[1:]
    assert [(p.name, p.default) for p in parameters] == [
        ("sysid", inspect.Parameter.empty),
        ("position_m", (0.0, 0.0)),
    ]
    assert Module(4) == Module(4, (0.0, 0.0))


def test_classes_it_cannot_build_are_refused() -> None:
    @dataclass
    class Mutable:
        x: int

    @dataclass(frozen=True)
    class Checked:
        x: int

        def __post_init__(self) -> None:
            pass

    @dataclass(frozen=True)
    class Factory:
        x: list[int] = field(default_factory=list)

    @dataclass(frozen=True)
    class Derived:
        x: int
        y: int = field(init=False, default=0)

    @dataclass(frozen=True)
    class WithInitVar:
        x: int
        scale: InitVar[float] = 1.0

    class Plain:
        pass

    for cls in (Mutable, Checked, Factory, Derived, WithInitVar, Plain):
        with pytest.raises(TypeError, match="quick_init"):
            quick_init(cls)
