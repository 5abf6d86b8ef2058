"""Strangers in a real run (``configs/robustness.yaml``, which tracks them: lockstep, MAVLink
between the apps, the regions read back from the MCAP log): on 4 dB shadowing with 8 aircraft
the spoofer's region goes out flagged UNCONFIRMED seconds after it is first heard, long before
the detectors alert; no fleet aircraft ever gets one."""

from __future__ import annotations

from pathlib import Path

from ridsafe.common.config import with_overrides
from ridsafe.common.messages import RegionFlags
from ridsafe.tools.run.lockstep import run_lockstep
from ridsafe.tools.run.scenario import REPO_ROOT, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.reader import read_records

SPOOFER = "RSAF800000666"


def _fly(tmp_path: Path, strangers_after_claims: int) -> tuple[list[tuple[float, str, int]], float]:
    """Seed 7 at 4 dB, 8 aircraft, 16 s: every region sent (t, serial, flags), the alert."""
    overrides: dict[str, object] = {
        "scenario.seed": 7,
        "scenario.duration_s": 16.0,
        "scenario.radio.shadowing_sigma_db": 4.0,
        "pipeline.tracks.strangers_after_claims": strangers_after_claims,
    }
    loaded = load_scenario_file(REPO_ROOT / "configs" / "robustness.yaml")
    loaded = with_aircraft(with_overrides(loaded, overrides), 8, overrides)
    log = tmp_path / f"strangers{strangers_after_claims}.mcap"
    assert run_lockstep(loaded, "aware", log, recorder_process=False).status == "completed"
    regions, alerts = [], []
    for topic, t, r in read_records(log, {"/gcs/unsafe_regions", "/gcs/alerts"}):
        if topic == "/gcs/alerts" and r["state"] == "raised":
            alerts.append((t, r["uas_id"]))
        elif topic == "/gcs/unsafe_regions":
            regions.append((t, str(r["uas_id"]), int(r["flags"])))
    ((alert_s, alerted),) = alerts
    assert alerted == SPOOFER
    return regions, alert_s


def test_the_spoofers_region_comes_before_its_alert_flagged_unconfirmed(tmp_path: Path) -> None:
    regions, alert_s = _fly(tmp_path, 5)  # the config's own setting
    assert {serial for _, serial, _ in regions} == {SPOOFER}
    first_s = regions[0][0]
    assert first_s < 8.0 < alert_s  # in the first seconds, the alert at 13.5 s
    for t, _, flags in regions:
        assert bool(flags & RegionFlags.UNCONFIRMED) == (t < alert_s), t
    # Without: nothing until the alert (which comes at another time: the aircraft that kept
    # clear of the stranger's region heard it from elsewhere).
    plain, plain_alert_s = _fly(tmp_path, 0)
    assert plain and plain[0][0] >= plain_alert_s
    assert not any(f & RegionFlags.UNCONFIRMED for _, _, f in plain)
