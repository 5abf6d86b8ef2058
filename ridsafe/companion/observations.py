"""Heard Remote ID broadcasts -> observation reports for the GCS.

Two layers:

1. ``RssiSource``: where received RID LOCATIONs and their signal strength come from. The
   companion hands every MAVLink message of its RID transponder to ``on_mavlink`` and
   collects ``HeardBroadcast`` values from ``poll``; nothing above this interface knows which
   source it is. ``SimTransponderRssi`` is the sim transponder's: each OPEN_DRONE_ID_LOCATION
   is followed by a RIDSAFE_RID_RSSI with the same ``id_or_mac`` (a LOCATION inside an
   OPEN_DRONE_ID_MESSAGE_PACK by the pack's RSSI). A real RID receiver
   (Wi-Fi / Bluetooth capture with RSSI) will be another implementation that ignores MAVLink.
2. ``make_observation`` + ``ObservationBatcher``: a heard broadcast becomes an
   ``Observation`` with the receiver's own position at the receive time and is sent to the
   GCS in the next batch. Every heard broadcast is either reported exactly once or counted
   under the reason it could not be (no RSSI, no own position, no claimed position).

Receiver position (``OwnTelemetry.fix``): the latest GLOBAL_POSITION_INT, moved along its NED
velocity to the receive time (at most ``max_extrapolation_s``), with the WGS-84 radii of
curvature::

    lat' = lat + v_n dt / (M + h),   lon' = lon + v_e dt / ((N + h) cos lat),   h' = h - v_d dt
    M = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2),   N = a / (1 - e^2 sin^2 lat)^(1/2)

(exact to well below a millimetre over the < 10 m an aircraft moves between two fixes).
"""

from __future__ import annotations

import functools
import logging
import math
from collections import deque
from collections.abc import Iterable
from dataclasses import asdict, dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from ridsafe.common import codec, frames, rid
from ridsafe.common import messages as m
from ridsafe.common.errors import RidsafeError
from ridsafe.common.frozen import quick_init
from ridsafe.companion.rid import Periodic

__all__ = [
    "HeardBroadcast",
    "ObservationBatcher",
    "ObservationCounters",
    "OwnTelemetry",
    "PairingCounters",
    "ReceiverFix",
    "RssiSource",
    "SimTransponderRssi",
    "batch_record",
    "claimed_id",
    "make_observation",
]

logger = logging.getLogger(__name__)

#: OPEN_DRONE_ID_LOCATION.timestamp "unknown" (seconds after the hour, 0xFFFF).
UNKNOWN_RID_TIMESTAMP_S = float(codec.ODID_UNKNOWN_TIMESTAMP_S)
#: A telemetry clock sample this far below the offset estimate: the autopilot rebooted.
CLOCK_RESET_S = 1.0
_ODID_TYPES = (
    m.OdidBasicId,
    m.OdidSystem,
    m.OdidSystemUpdate,
    m.OdidOperatorId,
    m.OdidSelfId,
    m.OdidRaw,
)


_LOCATION = int(m.OdidMessageType.LOCATION)
_PACK = int(m.OdidMessageType.MESSAGE_PACK)
_PairKey = tuple[bytes, int]  # (id_or_mac, F3411 type of the frame)


@quick_init
@dataclass(frozen=True, slots=True)
class HeardBroadcast:
    """One received RID LOCATION, its RSSI (None: none came with it) and when it was heard
    (companion clock)."""

    location: m.OdidLocation
    rssi_dbm: float | None
    rx_t_s: float


class RssiSource(Protocol):
    """Received RID locations with signal strength, whatever the radio."""

    name: str

    def on_mavlink(self, now_s: float, message: m.Message) -> None:
        """A message from the RID transponder component (sources that use none ignore it)."""
        ...

    def poll(self, now_s: float) -> list[HeardBroadcast]:
        """Broadcasts completed since the last call, oldest first."""
        ...

    def counters(self) -> dict[str, int]: ...


@dataclass
class PairingCounters:
    paired: int = 0
    out_of_order: int = 0  # the RSSI came before its LOCATION
    location_without_rssi: int = 0  # handed on with rssi None
    rssi_without_location: int = 0  # dropped: nothing to attach it to
    rssi_other_type: int = 0  # RSSI of BASIC_ID, SYSTEM, a pack without LOCATION: not used
    other_odid: int = 0  # BASIC_ID, SYSTEM, a pack without LOCATION...: not used
    bad_pack: int = 0  # a message pack, or a LOCATION in one, that does not decode


class SimTransponderRssi:
    """Pairs each OPEN_DRONE_ID_LOCATION with the RIDSAFE_RID_RSSI of the same ``id_or_mac``.

    Per id, LOCATIONs and LOCATION-type RSSIs wait in two FIFO queues and pair oldest with
    oldest in whichever order they come. One left alone for ``pair_timeout_s`` expires
    (checked on every message of its id and on every poll, so a stale one never pairs with
    the next second's): a LOCATION is handed on without RSSI (it still tells where a
    neighbour claims to be), an RSSI is dropped; both are counted.
    """

    name = "sim-transponder"

    def __init__(self, pair_timeout_s: float = 0.5) -> None:
        self.pair_timeout_s = pair_timeout_s
        self.stats = PairingCounters()
        # Keyed by (id_or_mac, the frame's F3411 type: LOCATION, or MESSAGE_PACK for a
        # LOCATION that came in a pack and pairs with the pack's RSSI).
        self._locations: dict[_PairKey, deque[tuple[float, m.OdidLocation]]] = {}
        self._rssi: dict[_PairKey, deque[tuple[float, m.RidRssi]]] = {}
        self._ready: list[HeardBroadcast] = []

    def on_mavlink(self, now_s: float, message: m.Message) -> None:
        if isinstance(message, m.OdidLocation):
            self._on_location(now_s, message, _LOCATION)
        elif isinstance(message, m.RidRssi):
            self._on_rssi(now_s, message)
        elif isinstance(message, m.OdidRaw) and message.name == rid.MESSAGE_PACK_NAME:
            self._on_pack(now_s, message)
        elif isinstance(message, _ODID_TYPES):
            self.stats.other_odid += 1

    def _on_location(self, now_s: float, location: m.OdidLocation, frame_type: int) -> None:
        self._expire(now_s - self.pair_timeout_s, location.id_or_mac)
        key = (location.id_or_mac, frame_type)
        waiting = self._rssi.get(key)
        if waiting:
            _, rssi = waiting.popleft()
            self.stats.out_of_order += 1
            self._pair(now_s, location, rssi)
        else:
            self._locations.setdefault(key, deque()).append((now_s, location))

    def _on_pack(self, now_s: float, pack: m.OdidRaw) -> None:
        """A received message pack: a LOCATION in it pairs with the pack's RSSI."""
        try:
            found = rid.location_in_pack(pack)
        except RidsafeError as exc:
            self.stats.bad_pack += 1
            logger.info("unreadable message pack: %s", exc)
            return
        for error in found.errors:
            self.stats.bad_pack += 1
            logger.info("unreadable LOCATION in a message pack: %s", error)
        locations = [loc for loc in found.messages if isinstance(loc, m.OdidLocation)]
        if not locations:
            self.stats.other_odid += 1
        for location in locations:
            self._on_location(now_s, location, _PACK)

    def _on_rssi(self, now_s: float, rssi: m.RidRssi) -> None:
        self._expire(now_s - self.pair_timeout_s, rssi.id_or_mac)
        key = (rssi.id_or_mac, rssi.odid_message_type)
        waiting = self._locations.get(key)
        if waiting:
            rx_t_s, location = waiting.popleft()
            self._pair(rx_t_s, location, rssi)
        elif rssi.odid_message_type == _LOCATION:  # its LOCATION may still come
            self._rssi.setdefault(key, deque()).append((now_s, rssi))
        else:  # BASIC_ID, SYSTEM, a pack without LOCATION (a pack comes before its RSSI)
            self.stats.rssi_other_type += 1

    def _pair(self, rx_t_s: float, location: m.OdidLocation, rssi: m.RidRssi) -> None:
        self.stats.paired += 1
        self._ready.append(HeardBroadcast(location, rssi.rssi_dbm, rx_t_s))

    def poll(self, now_s: float) -> list[HeardBroadcast]:
        self._expire(now_s - self.pair_timeout_s)
        out, self._ready = self._ready, []
        out.sort(key=lambda heard: heard.rx_t_s)
        return out

    def _expire(self, cutoff_s: float, id_or_mac: bytes | None = None) -> None:
        """Settle what waited since before ``cutoff_s`` (for one id, or all): a LOCATION
        goes on without RSSI, an RSSI is dropped."""
        keys = None if id_or_mac is None else [(id_or_mac, _LOCATION), (id_or_mac, _PACK)]
        for rx_t_s, location in _take_old(self._locations, cutoff_s, keys):
            self.stats.location_without_rssi += 1
            logger.info("RID LOCATION from %r came without RSSI", location.id_or_mac)
            self._ready.append(HeardBroadcast(location, None, rx_t_s))
        for _, rssi in _take_old(self._rssi, cutoff_s, keys):
            self.stats.rssi_without_location += 1
            logger.info("RSSI for %r came without its LOCATION; dropped", rssi.id_or_mac)

    def counters(self) -> dict[str, int]:
        return dict(asdict(self.stats))


def _take_old(
    queues: dict[_PairKey, deque[tuple[float, Any]]],
    cutoff_s: float,
    keys: list[_PairKey] | None,
) -> list[Any]:
    """Remove and return the entries received before ``cutoff_s`` (of ``keys``, or all);
    drop emptied queues."""
    out: list[Any] = []
    for key in list(queues) if keys is None else keys:
        queue = queues.get(key)
        if queue is None:
            continue
        while queue and queue[0][0] < cutoff_s:
            out.append(queue.popleft())
        if not queue:
            del queues[key]
    return out


# --- the receiver's own position ---------------------------------------------------------------


@quick_init
@dataclass(frozen=True, slots=True)
class ReceiverFix:
    """The latest GLOBAL_POSITION_INT: WGS-84 position, NED velocity, companion time it came."""

    t_s: float
    lat_deg: float
    lon_deg: float
    alt_m: float
    v_ned_m_s: m.Vec3

    def at(self, t_s: float, max_extrapolation_s: float) -> tuple[float, float, float]:
        """(lat_deg, lon_deg, alt_m) at ``t_s``, extrapolated along the velocity (bounded)."""
        dt = min(max(t_s - self.t_s, -max_extrapolation_s), max_extrapolation_s)
        vn, ve, vd = self.v_ned_m_s
        lat = math.radians(self.lat_deg)
        w = 1.0 - frames.WGS84_E2 * math.sin(lat) ** 2
        radius_n = frames.WGS84_A_M / math.sqrt(w)
        radius_m = frames.WGS84_A_M * (1.0 - frames.WGS84_E2) / w**1.5
        dlat = vn * dt / (radius_m + self.alt_m)
        dlon = ve * dt / ((radius_n + self.alt_m) * max(math.cos(lat), 1e-9))
        return (
            self.lat_deg + math.degrees(dlat),
            self.lon_deg + math.degrees(dlon),
            self.alt_m - vd * dt,
        )


def _vec3(values: NDArray[np.float64] | tuple[float, ...]) -> m.Vec3:
    return (float(values[0]), float(values[1]), float(values[2]))


class OwnTelemetry:
    """The aircraft as its autopilot reports it, with the companion time each report came.

    Besides the receiver's position (``fix``) it gives the companion its own Remote ID state,
    UNIX time (SYSTEM_TIME advanced by the time since it came), the geodetic <-> local NED
    conversions about HOME_POSITION (shifted by home's local x, y, z) and the estimate of the
    autopilot's clock: ``sim_time(now) = now + offset``, offset = the largest
    ``time_boot - arrival`` seen (the sample with the least latency), restarted when a sample
    falls ``CLOCK_RESET_S`` below it (the autopilot rebooted).
    """

    def __init__(self) -> None:
        self.heartbeat: m.Heartbeat | None = None
        self.heartbeat_s: float | None = None
        self.gpi: m.GlobalPositionInt | None = None
        self.gpi_s = 0.0
        self.lpn: m.LocalPositionNed | None = None
        self.home: m.HomePosition | None = None
        self.home_origin: frames.GeodeticOrigin | None = None
        self.system_time: m.SystemTime | None = None
        self.system_time_s = 0.0
        self.clock_offset_s: float | None = None

    def observe_clock(self, now_s: float, time_boot_s: float) -> None:
        sample = time_boot_s - now_s
        offset = self.clock_offset_s
        if offset is None or sample > offset or sample < offset - CLOCK_RESET_S:
            self.clock_offset_s = sample

    def sim_time(self, now_s: float) -> float:
        """``now_s`` on the autopilot's clock (itself until telemetry has come)."""
        return now_s if self.clock_offset_s is None else now_s + self.clock_offset_s

    def set_home(self, home: m.HomePosition) -> None:
        origin = frames.GeodeticOrigin(home.lat_deg, home.lon_deg, home.alt_msl_m)
        if origin != self.home_origin:
            self.home_origin = origin  # only a changed home: origins key a cache in frames
        self.home = home

    @property
    def armed(self) -> bool:
        return self.heartbeat is not None and self.heartbeat.armed

    def unix_s(self, now_s: float) -> float | None:
        """UNIX time now: SYSTEM_TIME advanced by the time since it came (None: unknown)."""
        st = self.system_time
        if st is None or st.time_unix_s <= 0.0:
            return None
        return st.time_unix_s + (now_s - self.system_time_s)

    def fix(self) -> ReceiverFix | None:
        gpi = self.gpi
        if gpi is None:
            return None
        return ReceiverFix(self.gpi_s, gpi.lat_deg, gpi.lon_deg, gpi.alt_msl_m, gpi.v_ned_m_s)

    def to_local(self, lat_deg: float, lon_deg: float, alt_m: float) -> m.Vec3:
        """WGS-84 -> the autopilot's local NED (needs HOME_POSITION)."""
        if self.home_origin is None or self.home is None:
            raise LookupError("no HOME_POSITION yet")
        e, n, u = frames.geodetic_to_enu_point(self.home_origin, lat_deg, lon_deg, alt_m)
        hn, he, hd = self.home.p_ned_m
        return (n + hn, e + he, -u + hd)

    def to_geodetic(self, p_ned_m: m.Vec3) -> tuple[float, float, float]:
        if self.home_origin is None or self.home is None:
            raise LookupError("no HOME_POSITION yet")
        hn, he, hd = self.home.p_ned_m
        north, east, down = p_ned_m[0] - hn, p_ned_m[1] - he, p_ned_m[2] - hd
        return frames.enu_to_geodetic_point(self.home_origin, east, north, -down)

    def rid_state(
        self, now_s: float, emergency: bool, max_extrapolation_s: float
    ) -> rid.OwnState | None:
        unix_s, fix, gpi = self.unix_s(now_s), self.fix(), self.gpi
        if unix_s is None or fix is None or gpi is None:
            return None
        lat, lon, alt = fix.at(now_s, max_extrapolation_s)
        height = gpi.relative_alt_m + (alt - gpi.alt_msl_m)
        speed = math.hypot(*gpi.v_ned_m_s)
        airborne = self.armed and (height > 0.5 or speed > 0.5)
        return rid.OwnState(unix_s, lat, lon, alt, height, gpi.v_ned_m_s, airborne, emergency)


# --- observations ------------------------------------------------------------------------------


@dataclass
class ObservationCounters:
    heard: int = 0
    reported: int = 0
    no_rssi: int = 0
    no_own_position: int = 0
    no_claimed_position: int = 0
    unknown_rid_timestamp: int = 0  # reported with timestamp 0xFFFF
    batches: int = 0
    sent_before_gcs_seen: int = 0


@functools.lru_cache(maxsize=1024)
def claimed_id(id_or_mac: bytes) -> str:
    """The claimed UAS id as text: printable ASCII kept, anything else as '?'."""
    return "".join(chr(b) if 32 <= b < 127 else "?" for b in id_or_mac[: codec.ODID_ID_LEN])


def make_observation(
    heard: HeardBroadcast, fix: ReceiverFix, t_s: float, max_extrapolation_s: float
) -> m.Observation | str:
    """The report of ``heard`` (``t_s``: its receive time on the clock reports use), or the
    reason it cannot be made."""
    loc = heard.location
    if heard.rssi_dbm is None:
        return "no_rssi"
    claimed_alt = loc.alt_geodetic_m if loc.alt_geodetic_m is not None else loc.alt_baro_m
    if loc.lat_deg is None or loc.lon_deg is None or claimed_alt is None:
        return "no_claimed_position"
    rx_lat, rx_lon, rx_alt = fix.at(heard.rx_t_s, max_extrapolation_s)
    timestamp = UNKNOWN_RID_TIMESTAMP_S if loc.timestamp_s is None else loc.timestamp_s
    return m.Observation(
        t_s=t_s,
        rx_lat_deg=rx_lat,
        rx_lon_deg=rx_lon,
        rx_alt_m=rx_alt,
        claimed_lat_deg=loc.lat_deg,
        claimed_lon_deg=loc.lon_deg,
        claimed_alt_m=claimed_alt,
        rid_timestamp_s=timestamp,
        rssi_dbm=heard.rssi_dbm,
        claimed_course_deg=loc.course_deg,
        claimed_speed_horizontal_m_s=loc.speed_horizontal_m_s,
        claimed_speed_vertical_m_s=loc.speed_vertical_m_s,
        uas_id=claimed_id(loc.id_or_mac),
    )


@dataclass
class ObservationBatcher:
    """Collects observations and releases them once per ``period_s``, in arrival order."""

    period_s: float
    counters: ObservationCounters = field(default_factory=ObservationCounters)
    _pending: list[m.Observation] = field(default_factory=list)
    _timer: Periodic | None = None

    def add(
        self,
        heard: HeardBroadcast,
        fix: ReceiverFix | None,
        t_s: float,
        max_extrapolation_s: float,
    ) -> None:
        self.counters.heard += 1
        if fix is None:
            self._skip("no_own_position", heard)
            return
        made = make_observation(heard, fix, t_s, max_extrapolation_s)
        if isinstance(made, str):
            self._skip(made, heard)
            return
        if heard.location.timestamp_s is None:
            self.counters.unknown_rid_timestamp += 1
        self._pending.append(made)

    def _skip(self, reason: str, heard: HeardBroadcast) -> None:
        """Count a broadcast that cannot be reported (first of each reason at WARNING)."""
        count = getattr(self.counters, reason) + 1
        setattr(self.counters, reason, count)
        level = logging.WARNING if count == 1 and reason != "no_rssi" else logging.DEBUG
        logger.log(
            level, "RID from %r not reported: %s (counted)", heard.location.id_or_mac, reason
        )

    def take_due(self, now_s: float) -> list[m.Observation]:
        """The batch, if one is due now and not empty."""
        if self._timer is None:
            self._timer = Periodic(self.period_s)
        if not self._timer.due(now_s) or not self._pending:
            return []
        out, self._pending = self._pending, []
        self.counters.batches += 1
        self.counters.reported += len(out)
        return out

    def take_all(self) -> list[m.Observation]:
        out, self._pending = self._pending, []
        self.counters.reported += len(out)
        return out


def batch_record(sysid: int, batch: Iterable[m.Observation]) -> dict[str, object]:
    """The ``/companion/observations`` record of one batch."""
    items = [
        {
            "t_s": o.t_s,
            "uas_id": o.uas_id,
            "rid_timestamp_s": o.rid_timestamp_s,
            "rssi_dbm": o.rssi_dbm,
            "rx_lat_deg": o.rx_lat_deg,
            "rx_lon_deg": o.rx_lon_deg,
            "rx_alt_m": o.rx_alt_m,
            "claimed_lat_deg": o.claimed_lat_deg,
            "claimed_lon_deg": o.claimed_lon_deg,
            "claimed_alt_m": o.claimed_alt_m,
        }
        for o in batch
    ]
    return {"sysid": sysid, "items": items}
