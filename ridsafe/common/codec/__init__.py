"""The MAVLink codec: domain messages <-> MAVLink 2 bytes. The only package that knows scales.

``MavlinkLink`` is one end of one MAVLink link, sans I/O: ``pack(message) -> bytes`` and
``feed(bytes) -> list[Received]``. It numbers outgoing packets, signs them when a key is
configured, and never raises on bad input: malformed frames, unknown message ids, values
out of range and unsigned or wrongly signed packets are logged, counted in ``LinkCounters``
and dropped, and parsing goes on with the next frame. Every piece of state (sequence numbers,
parse buffer, signing) belongs to one link; the modules below keep none.

Modules, by what they hold:

- ``units``: scales (degE7, cm/s, mm, us) and Open Drone ID "unknown" sentinels;
- ``standard``, ``odid``, ``ridsafe_messages``: per message, domain -> MAVLink fields and
  back, and each module's table (common.xml; OPEN_DRONE_ID_*; the ridsafe dialect);
- ``registry``: the joined table, ``to_mavlink`` / ``from_mavlink``;
- ``fields``: domain messages <-> field-value dicts (what ``common.f3411`` encodes);
- ``wire``: CRC, header, a payload's bytes (``encode_payload``) and its decoded view;
- ``signing``: keys, the outgoing signature and the per-stream replay check;
- ``link``: ``MavlinkLink``, ``Received``, ``LinkCounters``; with ``columnar=True`` (the
  GCS's) a sender's consecutive RIDSAFE_OBSERVATION(_PACK) packets are decoded together
  (``observation_kernels``, compiled) into one ``messages.ObservationRows``.

This package re-exports the names the apps use, so ``codec.MavlinkLink`` is the way in.
"""

from ridsafe.common.codec.fields import message_from_fields, odid_fields
from ridsafe.common.codec.link import (
    LinkCounters,
    MavlinkLink,
    Received,
    frame_rid_reports,
    warm_up_batches,
    warm_up_columnar,
)
from ridsafe.common.codec.registry import from_mavlink, to_mavlink
from ridsafe.common.codec.ridsafe_messages import (
    OBSERVATIONS_PER_PACK,
    observation_rows_payloads,
    pack_rows,
)
from ridsafe.common.codec.signing import (
    SIGNING_EPOCH_UNIX_S,
    ReplayWindow,
    SigningConfig,
    load_signing_key,
    signing_timestamp_from_unix,
)
from ridsafe.common.codec.units import (
    DEG_E7,
    ODID_ID_LEN,
    ODID_UNKNOWN_ALT_M,
    ODID_UNKNOWN_DIRECTION_CDEG,
    ODID_UNKNOWN_SPEED_H_CMS,
    ODID_UNKNOWN_SPEED_V_CMS,
    ODID_UNKNOWN_TIMESTAMP_S,
)
from ridsafe.common.codec.wire import (
    Payload,
    RidFrameTails,
    encode_payload,
    encode_payloads,
    x25_crc,
)

__all__ = [
    "DEG_E7",
    "OBSERVATIONS_PER_PACK",
    "ODID_ID_LEN",
    "ODID_UNKNOWN_ALT_M",
    "ODID_UNKNOWN_DIRECTION_CDEG",
    "ODID_UNKNOWN_SPEED_H_CMS",
    "ODID_UNKNOWN_SPEED_V_CMS",
    "ODID_UNKNOWN_TIMESTAMP_S",
    "SIGNING_EPOCH_UNIX_S",
    "LinkCounters",
    "MavlinkLink",
    "Payload",
    "Received",
    "ReplayWindow",
    "RidFrameTails",
    "SigningConfig",
    "encode_payload",
    "encode_payloads",
    "frame_rid_reports",
    "from_mavlink",
    "load_signing_key",
    "message_from_fields",
    "observation_rows_payloads",
    "odid_fields",
    "pack_rows",
    "signing_timestamp_from_unix",
    "to_mavlink",
    "warm_up_batches",
    "warm_up_columnar",
    "x25_crc",
]
