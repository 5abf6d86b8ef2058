"""The run log's topics: names, who writes them, and what each record holds.

One run = one MCAP file (``OUT/run.mcap``) with JSON-schema channels, log time = sim time.
Metrics are computed from these records alone. Frames: ``*_enu_m`` is the scenario's local
ENU frame about ``scenario.origin`` (the sim's truth frame; the GCS estimates in it too);
``*_ned_m`` is a companion's local NED frame at its home; geodetic fields are WGS-84.

The recorder stores ``t_s`` (the sim time passed to ``LogSink.log``) in every record, so
writers need not repeat it. Each entry of ``TOPICS`` maps a topic to (writer, required
fields). Writers must provide at least the required fields; extra fields are allowed.
``schema(topic)`` turns that into the JSON schema the recorder registers.
"""

from __future__ import annotations

from typing import Any

RUN_META = "/run/meta"
RUN_END = "/run/end"
TRUTH = "/truth/vehicles"
RADIO_TX = "/radio/transmissions"
RADIO_RX = "/radio/receptions"
OBSERVATIONS = "/companion/observations"
DECISIONS = "/companion/decisions"
COMPANION_EVENTS = "/companion/events"
ALERTS = "/gcs/alerts"
TRACKS = "/gcs/tracks"
REGIONS = "/gcs/unsafe_regions"
GCS_CYCLE = "/gcs/cycle"
DETECTOR_STATS = "/gcs/detector_stats"
GCS_CHANNEL = "/gcs/channel"
APP_COUNTERS = "/app/counters"
SIM_EVENTS = "/sim/events"

# topic -> (writer, {field: description})
TOPICS: dict[str, tuple[str, dict[str, str]]] = {
    RUN_META: (
        "runner, once at t=0",
        {
            "mode": "'lockstep' or 'live'",
            "seed": "scenario seed",
            "planner": "planner name",
            "scenario": "the whole scenario file as plain data (config.to_mapping)",
            "aircraft": "[{sysid, serial, start_enu_m, goal_enu_m, cruise_alt_m}] benign only",
            "spoofer": "{sysid, serial, offset_enu_m} of the first spoofer, or null",
            "adversaries": "[{sysid, serial, role: spoofer|ghost, claim, tx_power, ...}]",
            "nmac_threshold_m": "50.0",
        },
    ),
    RUN_END: (
        "runner, once at the end",
        {
            "wall_clock_s": "wall-clock duration of the run",
            "sim_time_s": "sim time reached",
            "status": "'completed', 'interrupted' or 'failed'",
            "reason": "why it ended ('' when completed)",
        },
    ),
    TRUTH: (
        "sim backend, 10 Hz",
        {
            "sysid": "[N] system ids, benign 1..n then the spoofer",
            "p_enu_m": "[N][3] true positions",
            "v_enu_m_s": "[N][3] true velocities",
            "armed": "[N] bools",
            "mode": "[N] ArduCopter custom modes",
            "spoofer_sysid": "system id of the spoofer or null",
            "spoofer_claimed_p_enu_m": "[3] where the spoofer's RID says it is, or null",
            "adversaries": "[{sysid, serial, role, claimed_p_enu_m, claimed_v_enu_m_s, silent, "
            "tx_power_dbm}] every spoofer and ghost (its true state: p_enu_m at its sysid)",
        },
    ),
    RADIO_TX: (
        "sim backend, each tick with transmissions",
        {"items": "[{sender: sysid, msg_type: F3411 type}]"},
    ),
    RADIO_RX: (
        "sim backend, each tick with receptions",
        {"items": "[{sender, receiver: sysid, msg_type, rssi_dbm}]"},
    ),
    OBSERVATIONS: (
        "companion, each batch sent to the GCS",
        {
            "sysid": "receiver",
            "items": "[{t_s, uas_id, rid_timestamp_s, rssi_dbm, rx_lat_deg, rx_lon_deg, "
            "rx_alt_m, claimed_lat_deg, claimed_lon_deg, claimed_alt_m}]",
        },
    ),
    DECISIONS: (
        "companion, each planner decision",
        {
            "sysid": "deciding aircraft",
            "planner": "planner name",
            "status": "planner status (e.g. 'cruise', 'arrived', 'no_safe_action')",
            "target_p_ned_m": "[3] target in the aircraft's local NED",
            "target_v_ned_m_s": "[3]",
            "target_lat_deg": "target latitude",
            "target_lon_deg": "target longitude",
            "target_alt_m": "target geodetic altitude",
            "compute_ms": "time the decision took",
            "n_neighbours": "neighbours considered",
            "n_regions": "unsafe regions considered",
        },
    ),
    COMPANION_EVENTS: (
        "companion, on each event",
        {"sysid": "aircraft", "event": "event name", "detail": "free text"},
    ),
    ALERTS: (
        "GCS, when an alert is raised or cleared",
        {
            "uas_id": "transmitter serial",
            "detector": "detector name (RidsafeDetector member name, lower case)",
            "statistic": "test statistic",
            "threshold": "its threshold",
            "state": "'raised' or 'cleared'",
        },
    ),
    TRACKS: (
        "GCS, each cycle per live track",
        {
            "uas_id": "tracked transmitter",
            "track_id": "GCS track id",
            "p_enu_m": "[3] estimated position",
            "cov_enu_m2": "[3][3] position covariance",
            "v_enu_m_s": "[3] estimated velocity",
            "mode_probabilities": "[CV, CA]",
            "fix": "true when a multilateration fix updated the track this cycle",
        },
    ),
    REGIONS: (
        "GCS, each unsafe region sent",
        {
            "uas_id": "spoofer serial",
            "track_id": "GCS track id",
            "center_enu_m": "[3]",
            "cov_enu_m2": "[3][3]",
            "chi2_threshold": "chi2_3 quantile at 1 - alpha",
            "alpha": "risk level",
            "valid_until_s": "expiry (sim time)",
            "semi_axes_m": "[3] ellipsoid semi-axes, largest first",
        },
    ),
    GCS_CYCLE: (
        "GCS, every cycle",
        {
            "compute_ms": "time of the whole cycle (detection..regions)",
            "n_observations": "observations ingested since the last cycle",
            "n_transmissions": "transmissions processed",
            "n_tracks": "live tracks",
        },
    ),
    GCS_CHANNEL: (
        "GCS, when it takes a channel model (pipeline.calibration)",
        {
            "channel": (
                "'configured' (pipeline.rssi_sigma_db, free space), 'provisional' (a fit "
                "before the full warm-up: calibration.provisional_*) or 'fitted'"
            ),
            "n_samples": "labelled benign-to-benign receptions behind the decision",
            "residual_std_db": "the receptions' residual std under the configured channel",
            "p_value": "chi-square p-value of the configured channel (null: not tested)",
            "exponent": "fitted path-loss exponent (null on the configured channel)",
            "sigma_db": "fitted noise std, dB (null on the configured channel)",
        },
    ),
    DETECTOR_STATS: (
        "GCS, per transmission (observed claim)",
        {
            "uas_id": "claimed transmitter",
            "detectors": "{detector name: {statistic, threshold, decision (statistic above "
            "threshold)}}, every detector's verdict on the claim",
        },
    ),
    SIM_EVENTS: (
        "sim backend, on each autopilot failsafe",
        {"sysid": "vehicle", "event": "'companion_loss'", "action": "'hold', 'land' or 'rtl'"},
    ),
    APP_COUNTERS: (
        "any app, at the end and every 10 s",
        {"app": "'sim', 'gcs', 'companion/<sysid>'", "counters": "{name: count}"},
    ),
}


def schema(topic: str) -> dict[str, Any]:
    """JSON schema of a topic's records (required fields, extra fields allowed)."""
    writer, fields = TOPICS[topic]
    return {
        "title": topic,
        "description": f"written by the {writer}",
        "type": "object",
        "properties": {name: {"description": text} for name, text in fields.items()},
        "required": list(fields),
    }
