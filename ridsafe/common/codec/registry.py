"""Which domain message is which MAVLink message, and the outbound values of one.

``CODECS`` joins the tables of the conversion modules (``standard``, ``odid``,
``ridsafe_messages``): domain class -> (MAVLink name, to-MAVLink, from-MAVLink). Adding a
message the apps exchange = its two functions in the right module plus one line in that
module's table (and, for a new dialect message, the XML and a regeneration).
"""

from __future__ import annotations

import functools
import inspect
import operator
import re
import struct
from collections.abc import Callable, Sequence
from typing import Any

from ridsafe.common import messages as m
from ridsafe.common.codec import odid, protocols, ridsafe_messages, standard
from ridsafe.common.codec.units import CodecTable, FromMav, Wire
from ridsafe.common.errors import WireError

CODECS: CodecTable = {
    **standard.CODECS,
    **odid.CODECS,
    **ridsafe_messages.CODECS,
    **protocols.CODECS,
}
_FROM_NAME: dict[str, FromMav] = {name: dec for name, _, dec in CODECS.values()}
for _name in odid.RAW_NAMES:
    _FROM_NAME[_name] = odid.odid_raw_from


def decoder_for(name: str) -> FromMav | None:
    """The from-MAVLink function of a message name (None: the apps do not use it)."""
    return _FROM_NAME.get(name)


def rows_decoder_for(name: str) -> Callable[[Sequence[bytes]], m.ObservationRows | None] | None:
    """The columnar decoding of a message name (many payloads at once), or None."""
    return ridsafe_messages.ROW_DECODERS.get(name)


def to_wire(message: m.Message) -> Wire:
    """The outbound form of a domain message (raises WireError if it has none or a value
    does not fit)."""
    if isinstance(message, m.OdidRaw):
        return odid.odid_raw_to(message)
    try:
        _, encode, _ = CODECS[type(message)]
    except KeyError:
        raise WireError(f"no MAVLink encoding for {type(message).__name__}") from None
    return encode(message)


def to_mavlink(message: m.Message) -> Any:
    """The pymavlink message object for a domain message (raises WireError if unencodable)."""
    wire = to_wire(message)
    return wire.cls(*wire.args)


def from_mavlink(raw: Any) -> m.Message | None:
    """The domain message for a pymavlink message, or None if the apps do not use it.

    Raises WireError for values that no valid sender produces (latitude 91 deg, NaN RSSI).
    """
    decode = _FROM_NAME.get(raw.get_type())
    return None if decode is None else decode(raw)


def wire_values(wire: Wire) -> tuple[Any, ...] | list[Any]:
    """The values ``wire_struct(wire.cls)`` packs: the fields in wire order, uint8 arrays as
    bytes (one ``s`` item), other arrays flattened, char arrays as bytes."""
    getter, arrays, chars, defaults = wire_plan(wire.cls)
    args = wire.args
    if len(args) < len(defaults):  # extension fields left to their constructor defaults
        args = args + defaults[len(args) :]
    values = getter(args)
    if not (arrays or chars):  # scalars only, the common case: one C call
        return values if isinstance(values, tuple) else (values,)
    out = list(values)
    for index in chars:
        if isinstance(out[index], str):
            out[index] = out[index].encode("latin-1")
    uint8_arrays = byte_arrays(wire.cls)
    for index in reversed(arrays):  # from the end: earlier indices stay valid
        length = uint8_arrays.get(index)
        if length is None:
            out[index : index + 1] = out[index]
            continue
        value = out[index]
        value = value if type(value) is bytes else bytes(value)
        if len(value) != length:  # as the unpacker's length-many B items would refuse
            raise WireError(f"{wire.cls.msgname}: {len(value)} values for uint8[{length}]")
        out[index] = value
    return out


@functools.cache
def wire_struct(cls: Any) -> struct.Struct:
    """``cls.unpacker`` with every uint8 array packed as one ``Ns`` item instead of N ``B``
    items: the same bytes, one value (bytes) per array instead of N Python ints."""
    return struct.Struct(_byte_array_format(cls))


def _byte_array_format(cls: Any) -> str:
    arrays = byte_arrays(cls)
    items = re.findall(r"(\d*)([a-zA-Z?])", cls.unpacker.format[1:])
    parts = [cls.unpacker.format[0]]
    for wire_index, (count, code) in enumerate(items):
        length = arrays.get(wire_index)
        parts.append(f"{length}s" if length is not None else f"{count}{code}")
    return "".join(parts)


@functools.cache
def byte_arrays(cls: Any) -> dict[int, int]:
    """Wire index -> length of every uint8 array of a message class."""
    xml_of_wire = sorted(range(len(cls.orders)), key=lambda i: cls.orders[i])
    return {
        w: n
        for w, n in enumerate(cls.array_lengths)
        if n > 0 and cls.fieldtypes[xml_of_wire[w]] == "uint8_t"
    }


@functools.cache
def wire_plan(
    cls: Any,
) -> tuple[Callable[[Any], Any], tuple[int, ...], tuple[int, ...], tuple[Any, ...]]:
    """(getter of the wire-ordered fields from the constructor arguments, wire indices of
    arrays, wire indices of char arrays, the constructor's defaults) of a message class.
    ``cls.orders[i]`` is the wire position of XML field i; ``array_lengths`` is in wire
    order, ``fieldtypes`` in XML order."""
    xml_of_wire = sorted(range(len(cls.orders)), key=lambda i: cls.orders[i])
    is_char = [cls.fieldtypes[i].startswith("char") for i in xml_of_wire]
    arrays = tuple(w for w, n in enumerate(cls.array_lengths) if n > 0 and not is_char[w])
    chars = tuple(w for w, char in enumerate(is_char) if char)
    parameters = list(inspect.signature(cls.__init__).parameters.values())[1:]  # after self
    defaults = tuple(p.default for p in parameters)
    return operator.itemgetter(*xml_of_wire), arrays, chars, defaults
