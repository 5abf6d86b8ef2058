"""Heard Remote ID frames -> neighbours and observation reports for the GCS.

``ObservationReporter`` takes the frames a RID receiver heard (``common.heard.HeardRidFrame``:
frame bytes, RSSI, receive time, all together from the radio on) and reads the messages in
each (``RidFrameDecoder``). What every LOCATION claims (``LocationClaim``) updates the
neighbour table and becomes a report (``observation_row``: an ``Observation``'s values) with
the RSSI of the frame it came in and the receiver's own position at the receive time; reports
go to the GCS in batches (``m.ObservationRows``), once per ``observation_batch_s``, three to
a message (RIDSAFE_OBSERVATION_PACK). Every LOCATION heard is either reported exactly once or
counted under the reason it could not be (no own position, no claimed position); frames that
do not decode, or carry no LOCATION, are counted too.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field

from ridsafe.common import codec, topics
from ridsafe.common import messages as m
from ridsafe.common.heard import HeardRidFrame, LocationClaim, RidFrameDecoder
from ridsafe.common.logsink import ItemRows, LogSink
from ridsafe.companion.neighbours import NeighbourTable
from ridsafe.companion.rid import Periodic
from ridsafe.companion.telemetry import OwnTelemetry

__all__ = [
    "MAX_PENDING_OBSERVATIONS",
    "ObservationBatcher",
    "ObservationCounters",
    "ObservationReporter",
    "ReportRow",
    "SendObservation",
    "batch_record",
    "observation_row",
]

logger = logging.getLogger(__name__)

#: OPEN_DRONE_ID_LOCATION.timestamp "unknown" (seconds after the hour, 0xFFFF).
UNKNOWN_RID_TIMESTAMP_S = float(codec.ODID_UNKNOWN_TIMESTAMP_S)


@dataclass
class ObservationCounters:
    frames: int = 0  # heard frames handed to the reporter
    frame_errors: int = 0  # frames, or messages in a pack, that did not decode
    frames_without_location: int = 0  # BASIC_ID, SYSTEM, a pack of static messages...
    heard: int = 0  # LOCATIONs read from the frames
    reported: int = 0
    no_own_position: int = 0
    no_claimed_position: int = 0
    unknown_rid_timestamp: int = 0  # reported with timestamp 0xFFFF
    batches: int = 0
    sent_before_gcs_seen: int = 0
    batch_full: int = 0  # dropped: the pending batch already held MAX_PENDING_OBSERVATIONS


#: One report as a batch keeps it: an ``Observation``'s values in ``m.OBSERVATION_COLUMNS``
#: order, NaN where unknown, as in ``m.ObservationRows`` (its claimed id goes beside it).
ReportRow = tuple[
    float, float, float, float, float, float, float, float, float, float, float, float
]  # fmt: skip


def observation_row(
    claim: LocationClaim, rssi_dbm: float, rx_geodetic: m.Vec3, t_s: float
) -> ReportRow | str:
    """The report of the LOCATION ``claim`` was read from, heard at ``rssi_dbm``
    (``rx_geodetic``: where the receiver was when it heard it, ``ReceiverFix.at``; ``t_s``:
    the receive time on the clock reports use), or the reason it cannot be made."""
    position = claim.position
    if position is None:
        return "no_claimed_position"
    loc = claim.location
    rx_lat, rx_lon, rx_alt = rx_geodetic
    claimed_lat, claimed_lon, claimed_alt = position
    timestamp = UNKNOWN_RID_TIMESTAMP_S if loc.timestamp_s is None else loc.timestamp_s
    course, speed_h, speed_v = loc.course_deg, loc.speed_horizontal_m_s, loc.speed_vertical_m_s
    return (
        t_s, rx_lat, rx_lon, rx_alt, claimed_lat, claimed_lon, claimed_alt, timestamp, rssi_dbm,
        math.nan if course is None else course,
        math.nan if speed_h is None else speed_h,
        math.nan if speed_v is None else speed_v,
    )  # fmt: skip


#: At most this many observations wait for one batch: a flood of RID frames (or a paused
#: clock) must not grow a companion's memory and its garbage collections without bound. A
#: real batch holds a few hundred at most (64 transmitters at 4 Hz over 0.5 s is 128).
MAX_PENDING_OBSERVATIONS = 4096


@dataclass
class ObservationBatcher:
    """Collects reports and releases them once per ``period_s``, in arrival order."""

    period_s: float
    counters: ObservationCounters = field(default_factory=ObservationCounters)
    _rows: list[ReportRow] = field(default_factory=list)
    _ids: list[str] = field(default_factory=list)  # each row's claimed id
    _timer: Periodic | None = None

    def add(
        self,
        claim: LocationClaim,
        rssi_dbm: float,
        rx_geodetic: m.Vec3 | None,
        t_s: float,
    ) -> None:
        """Batch the report of ``claim`` (``observation_row``; ``rx_geodetic`` None: the
        receiver does not know where it is)."""
        self.counters.heard += 1
        if rx_geodetic is None:
            self._skip("no_own_position", claim)
            return
        made = observation_row(claim, rssi_dbm, rx_geodetic, t_s)
        if isinstance(made, str):
            self._skip(made, claim)
            return
        if len(self._rows) >= MAX_PENDING_OBSERVATIONS:
            self._skip("batch_full", claim)
            return
        if claim.location.timestamp_s is None:
            self.counters.unknown_rid_timestamp += 1
        self._rows.append(made)
        self._ids.append(claim.uas_id)

    def _skip(self, reason: str, claim: LocationClaim) -> None:
        """Count a broadcast that cannot be reported (first of each reason at WARNING)."""
        count = getattr(self.counters, reason) + 1
        setattr(self.counters, reason, count)
        level = logging.WARNING if count == 1 else logging.DEBUG
        logger.log(
            level, "RID from %r not reported: %s (counted)", claim.location.id_or_mac, reason
        )

    def take_due(self, now_s: float) -> m.ObservationRows | None:
        """The batch, if one is due now and not empty."""
        if self._timer is None:
            self._timer = Periodic(self.period_s)
        if not self._timer.due(now_s) or not self._rows:
            return None
        self.counters.batches += 1
        return self.take_all()

    def take_all(self) -> m.ObservationRows | None:
        """Every report batched (None: none)."""
        if not self._rows:
            return None
        out = m.ObservationRows.of_rows(self._rows, self._ids)
        self._rows, self._ids = [], []
        self.counters.reported += len(out)
        return out


#: The fields of a report in a ``/companion/observations`` record's items, in order.
_RECORD_FIELDS = (
    "t_s",
    "uas_id",
    "rid_timestamp_s",
    "rssi_dbm",
    "rx_lat_deg",
    "rx_lon_deg",
    "rx_alt_m",
    "claimed_lat_deg",
    "claimed_lon_deg",
    "claimed_alt_m",
)


#: Where each of ``_RECORD_FIELDS`` is in ``m.OBSERVATION_COLUMNS`` (-1: the claimed id).
_RECORD_COLUMNS = tuple(
    -1 if name == "uas_id" else m.OBSERVATION_COLUMNS.index(name) for name in _RECORD_FIELDS
)


def batch_record(sysid: int, batch: m.ObservationRows) -> dict[str, object]:
    """The ``/companion/observations`` record of one batch."""
    by_column = batch.values.T.tolist()
    columns = tuple(list(batch.uas_id) if k < 0 else by_column[k] for k in _RECORD_COLUMNS)
    return {"sysid": sysid, "items": ItemRows(_RECORD_FIELDS, columns)}


#: Sends report messages to the GCS (a batch: ``ObservationRows``), in order.
SendObservation = Callable[[list[m.Message]], None]


class ObservationReporter:
    """Heard frames -> neighbour table and observation batches for the GCS (see the module
    docstring). Frames wait in ``hear`` until ``report`` reads them, so the receiver's own
    position is the one known at that step."""

    def __init__(
        self,
        sysid: int,
        period_s: float,
        max_extrapolation_s: float,
        neighbours: NeighbourTable,
        decoder: RidFrameDecoder | None = None,
    ) -> None:
        self.sysid = sysid
        self.max_extrapolation_s = max_extrapolation_s
        self.neighbours = neighbours
        self.decoder = decoder if decoder is not None else RidFrameDecoder()
        self.batcher = ObservationBatcher(period_s)
        self._heard: list[HeardRidFrame] = []

    @property
    def counters(self) -> ObservationCounters:
        return self.batcher.counters

    def hear(self, frames: Iterable[HeardRidFrame]) -> None:
        self._heard.extend(frames)

    def report(
        self, now_s: float, own: OwnTelemetry, gcs_seen: bool, send: SendObservation, sink: LogSink
    ) -> None:
        """Read what was heard since the last call, then send the batch if one is due."""
        heard_now, self._heard = self._heard, []
        fix = own.fix() if heard_now else None
        rx_t_s, rx_geodetic = math.nan, None  # the frames heard at one time: one position
        for heard in heard_now:
            rx_sim_s = own.sim_time(heard.rx_t_s)
            if fix is not None and heard.rx_t_s != rx_t_s:
                rx_t_s, rx_geodetic = heard.rx_t_s, fix.at(heard.rx_t_s, self.max_extrapolation_s)
            rssi_dbm = heard.report.rssi_dbm
            for claim in self._claims(heard):
                self.neighbours.update(rx_sim_s, claim)
                self.batcher.add(claim, rssi_dbm, rx_geodetic, rx_sim_s)
        self.send(now_s, self.batcher.take_due(now_s), own, gcs_seen, send, sink)

    def finish(
        self, now_s: float, own: OwnTelemetry, gcs_seen: bool, send: SendObservation, sink: LogSink
    ) -> None:
        """At the end of a run: send what is still batched."""
        self.send(now_s, self.batcher.take_all(), own, gcs_seen, send, sink)

    def send(
        self,
        now_s: float,
        batch: m.ObservationRows | None,
        own: OwnTelemetry,
        gcs_seen: bool,
        send: SendObservation,
        sink: LogSink,
    ) -> None:
        if batch is None:
            return
        if not gcs_seen:
            self.counters.sent_before_gcs_seen += len(batch)
        send([batch])
        sink.log(topics.OBSERVATIONS, own.sim_time(now_s), batch_record(self.sysid, batch))

    def _claims(self, heard: HeardRidFrame) -> tuple[LocationClaim, ...]:
        report = heard.report
        decoded = self.decoder.decode(report.frame, report.sender_id)
        counters = self.counters
        counters.frames += 1
        for error in decoded.errors:
            counters.frame_errors += 1
            level = logging.WARNING if counters.frame_errors == 1 else logging.DEBUG
            logger.log(level, "unreadable RID frame from %r: %s", heard.sender_id, error)
        claims = decoded.claims
        if not claims:
            counters.frames_without_location += 1
        return claims
