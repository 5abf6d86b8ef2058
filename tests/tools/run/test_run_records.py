"""The run's own records (``run.run_records``) and the metrics' reading of them: what the
runner writes in ``/run/meta`` is what ``analysis.run_arrays`` takes the run to be."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

from ridsafe.common import topics
from ridsafe.common.adversary import ClaimConfig, MotionConfig, SpooferConfig
from ridsafe.common.config import from_mapping
from ridsafe.tools.analysis.run_arrays import load_run
from ridsafe.tools.run import run_records
from ridsafe.tools.run.scenario import ScenarioFile, load_scenario_file, with_aircraft
from ridsafe.tools.runlog.writer import McapRecorder


def _loaded() -> ScenarioFile:
    return with_aircraft(load_scenario_file(None, {"companion.arrival_radius_m": 7.5}), 5)


def test_meta_describes_the_benign_aircraft_and_the_spoofer() -> None:
    loaded = _loaded()
    meta = run_records.run_meta(loaded, "lockstep", "aware")
    assert (meta["mode"], meta["planner"], meta["seed"]) == ("lockstep", "aware", 0)
    aircraft = meta["aircraft"]
    assert isinstance(aircraft, list)
    assert [a["sysid"] for a in aircraft] == [1, 2, 3, 4, 5]
    assert aircraft[2]["goal_enu_m"] == list(loaded.scenario.aircraft[2].goal_enu_m)
    assert loaded.scenario.spoofer is not None
    assert meta["spoofer"] == {
        "sysid": 6,
        "serial": loaded.scenario.spoofer.serial,
        "offset_enu_m": list(loaded.scenario.spoofer.offset_enu_m),
    }
    assert meta["nmac_threshold_m"] == run_records.NMAC_THRESHOLD_M
    # The whole scenario file, as plain data that loads back to the same file.
    assert from_mapping(ScenarioFile, meta["scenario"], "meta") == loaded


def test_meta_names_the_first_spoofer_that_lies_and_lists_a_bystander_by_its_role() -> None:
    loaded = _loaded()
    liar = loaded.scenario.spoofer
    assert liar is not None
    bystander = SpooferConfig(
        "RSAF800000888",
        motion=MotionConfig("line", 7.0, (-500.0, 0.0, 60.0), (500.0, 0.0, 60.0)),
        claim=ClaimConfig("truth"),
    )
    scenario = dataclasses.replace(loaded.scenario, spoofer=None, spoofers=(bystander, liar))
    meta = run_records.run_meta(dataclasses.replace(loaded, scenario=scenario), "lockstep", "aware")
    assert meta["spoofer"] == {"sysid": 7, "serial": liar.serial, "offset_enu_m": [50.0, 50.0, 0.0]}
    listed = meta["adversaries"]
    assert isinstance(listed, list)
    assert [(a["sysid"], a["serial"], a["role"], a["claim"]) for a in listed] == [
        (6, "RSAF800000888", "bystander", "truth"),
        (7, liar.serial, "spoofer", "offset"),
    ]


def test_end_records_an_unknown_sim_time_as_null() -> None:
    end = run_records.run_end(3.5, math.inf, "failed", "gcs exited with code 1")
    assert end == {
        "wall_clock_s": 3.5,
        "sim_time_s": None,
        "status": "failed",
        "reason": "gcs exited with code 1",
    }


def test_the_metrics_read_the_run_the_meta_describes(tmp_path: Path) -> None:
    loaded = _loaded()
    path = tmp_path / "run.mcap"
    with McapRecorder(path) as recorder:
        run_records.log_meta(recorder, run_records.run_meta(loaded, "live", "trust-rid"))
        recorder.log(topics.RUN_END, 12.0, run_records.run_end(2.0, 12.0, "completed", ""))
    run = load_run(path)
    assert run.benign_sysids == (1, 2, 3, 4, 5)
    assert run.goals_enu_m[4] == loaded.scenario.aircraft[3].goal_enu_m
    assert loaded.scenario.spoofer is not None
    assert (run.spoofer_sysid, run.spoofer_serial) == (6, loaded.scenario.spoofer.serial)
    assert run.nmac_threshold_m == run_records.NMAC_THRESHOLD_M
    assert run.arrival_radius_m == 7.5  # companion.arrival_radius_m
    assert run.end is not None and run.end["status"] == "completed"
