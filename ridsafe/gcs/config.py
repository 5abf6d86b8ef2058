"""The GCS shell's own configuration section (YAML ``gcs:``).

What the shell around the estimation pipeline needs: its cycle, how observation reports are
validated and grouped into transmissions, how much history it keeps, what it sends and how
often, and when a companion counts as gone. The estimation pipeline's parameters (detectors,
IMM, alpha) are a section of their own (``pipeline:``), not part of this one.

Times are sim seconds. ``clock`` says where the GCS's sim time comes from:

- ``local``: the runner's ``now_s`` is sim time (lockstep, or every process started together);
- ``peers``: sim time is learned from the receive times of the companions' reports. The first
  valid report fixes the offset between the runner's clock and sim time; until then the GCS
  sends heartbeats but runs no cycle. This is what a live GCS started before or after the
  companions needs.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

from ridsafe.common.checks import (
    check_at_least,
    check_increasing,
    check_positive,
    check_positive_fields,
)
from ridsafe.common.errors import FieldValueError

#: MAVLink identity of the GCS (a ground station, like QGroundControl / MAVProxy).
GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190


class ClockSource(enum.Enum):
    LOCAL = "local"
    PEERS = "peers"


@dataclass(frozen=True)
class GcsConfig:
    """See the module docstring; every field is checked in ``__post_init__``."""

    cycle_s: float = 0.25  # GCS update period (paper: 0.25 s)
    group_window_s: float = 0.3  # a transmission closes this long after its first reception
    history_window_s: float = 5.0  # reports received longer ago than this are rejected
    history_per_transmitter: int = 64  # closed transmissions kept per claimed id
    max_transmitters: int = 1024  # claimed ids with a history (least recent evicted)
    max_open_groups: int = 4096  # transmissions waiting to close
    future_tolerance_s: float = 0.5  # a report may be this far ahead of the GCS's sim time
    rssi_min_dbm: float = -150.0
    rssi_max_dbm: float = 30.0
    alt_min_m: float = -500.0  # geodetic altitude, receiver and claimed
    alt_max_m: float = 10_000.0
    max_distance_m: float = 100_000.0  # from the scenario origin, receiver and claimed
    region_validity_s: float = 1.0  # a region message is valid at most this long after sending
    alert_repeat_s: float = 1.0  # raised alerts are sent again this often (late joiners)
    heartbeat_hz: float = 1.0
    peer_timeout_s: float = 3.0  # a companion not heard this long gets nothing until it speaks
    max_peers: int = 512  # UDP senders with parser state (least recently heard dead one evicted)
    counters_period_s: float = 10.0  # /app/counters period
    warn_interval_s: float = 5.0  # at most one warning per reason and interval
    clock: ClockSource = ClockSource.LOCAL

    def __post_init__(self) -> None:
        positive = (
            "cycle_s",
            "group_window_s",
            "history_window_s",
            "region_validity_s",
            "alert_repeat_s",
            "heartbeat_hz",
            "peer_timeout_s",
            "counters_period_s",
        )
        check_positive_fields(
            self, *positive, may_be_zero=("future_tolerance_s", "warn_interval_s")
        )
        for name in ("history_per_transmitter", "max_transmitters", "max_open_groups", "max_peers"):
            check_at_least(name, getattr(self, name), 1)
        check_increasing("rssi_min_dbm", self.rssi_min_dbm, "rssi_max_dbm", self.rssi_max_dbm)
        check_increasing("alt_min_m", self.alt_min_m, "alt_max_m", self.alt_max_m)
        check_positive("max_distance_m", self.max_distance_m)
        if self.group_window_s >= self.history_window_s:
            raise FieldValueError(
                "group_window_s",
                f"expected less than history_window_s ({self.history_window_s}), "
                f"got {self.group_window_s}",
            )
