"""The project's error hierarchy.

Every error the project raises on purpose derives from :class:`RidsafeError`, so a runner can
catch "our" failures apart from bugs. Messages say what was expected and what came::

    RidsafeError
    +-- ConfigError        a configuration file or override is wrong (names file and key path)
    +-- FieldValueError    a dataclass field fails its own validation (also a ValueError)
    +-- WireError          bytes from the network are malformed (also a ValueError)
    +-- ClockError         time was asked to run backwards or became non-finite
    +-- UdpError           a UDP endpoint cannot do what was asked (e.g. no peer to reply to)
    +-- ConnectionStringError  a ``udpin:host:port`` style string is malformed (also a ValueError)

``FieldValueError`` is what a frozen dataclass's ``__post_init__`` raises to point at the
offending field; the config loader prefixes it with the file and the dataclass's key path, so
``FieldValueError("transition[1]", "row sums to 0.97, must be 1")`` raised while loading
``gcs.imm`` from ``configs/paper.yaml`` reads
``configs/paper.yaml: gcs.imm.transition[1]: row sums to 0.97, must be 1``.
"""

from __future__ import annotations

__all__ = [
    "ClockError",
    "ConfigError",
    "ConnectionStringError",
    "FieldValueError",
    "RidsafeError",
    "UdpError",
    "WireError",
]


class RidsafeError(Exception):
    """Base class of every error the project raises on purpose."""


class ConfigError(RidsafeError):
    """A configuration source (file or overrides) is malformed or fails validation.

    ``source`` is the file name (or ``"override"``), ``key_path`` the dotted key path inside it
    (``"gcs.imm.transition[1]"``; empty for the document itself or a syntax error) and ``reason``
    what was expected and what came. ``str(error)`` is ``"source: key_path: reason"``.
    """

    def __init__(self, source: str, key_path: str, reason: str) -> None:
        self.source = source
        self.key_path = key_path
        self.reason = reason
        where = f"{source}: {key_path}" if key_path else source
        super().__init__(f"{where}: {reason}")


class FieldValueError(RidsafeError, ValueError):
    """A dataclass field (or an element of it) fails validation in ``__post_init__``.

    ``field`` is the key path relative to the dataclass (``"transition[1]"``, ``"lat_deg"``).
    """

    def __init__(self, field: str, reason: str) -> None:
        self.field = field
        self.reason = reason
        super().__init__(f"{field}: {reason}")


class WireError(RidsafeError, ValueError):
    """Bytes from the wire are malformed (bad MAVLink frame, bad ASTM F3411 message, ...)."""


class ClockError(RidsafeError, ValueError):
    """A clock was asked to go backwards or to a non-finite time."""


class UdpError(RidsafeError):
    """A UDP endpoint cannot do what was asked (closed, or no peer known to send to)."""


class ConnectionStringError(RidsafeError, ValueError):
    """A connection string such as ``udpin:127.0.0.1:14550`` is malformed."""
