"""The same pymavlink probe (what a QGroundControl-style station asks at connect, then a
guided flight) against ``ridsafe sim`` and against a real ArduCopter SITL: the answers match."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from ridsafe.common import frames
from ridsafe.tools.run.scenario import load_scenario_file
from tests.sim_backend.mavlink_probe import ask
from tests.sim_backend.udp_sim import sim_on_udp
from tests.sitl import ROOT, arducopter, require_sitl

SIM_GCS, SIM_COMPANION = 26750, 27960
SITL_GCS, SITL_COMPANION, INSTANCE = 28750, 28760, 8
ACCEPTED = 0
# The sim's table is smaller than ArduCopter's 1,337 parameters: both must answer with many.
DIFFERENT_BY_DESIGN = {"params"}


def _ask_sim() -> dict[str, Any]:
    with sim_on_udp(SIM_GCS, SIM_COMPANION, speed=2.0):
        return ask(SIM_GCS)


def _ask_sitl(workdir: Path) -> dict[str, Any]:
    loaded = load_scenario_file(ROOT / "configs" / "default.yaml")
    start = np.array(loaded.scenario.aircraft[0].start_enu_m)
    lat, lon, alt = frames.enu_to_geodetic(loaded.scenario.origin, start)
    home = (float(lat), float(lon), float(alt))
    with arducopter(workdir, home, SITL_GCS, SITL_COMPANION, INSTANCE, speedup=4.0):
        return ask(SITL_GCS, ready_text="is using GPS")


def test_the_sim_alone_answers_every_question() -> None:
    pytest.importorskip("pymavlink")
    answers = _ask_sim()
    assert answers["params"] >= 30 and answers["RTL_ALT"] == 1500.0
    assert answers["count mission"] == 1  # home
    assert answers["count fence"] == answers["count rally"] == 0
    accepted = [k for k in answers if k.startswith(("interval", "cmd", "request", "COMMAND"))]
    assert all(answers[k] == ACCEPTED for k in accepted), answers
    assert all(answers[k] is True for k in answers if k.startswith("streamed")), answers
    assert answers["AUTOPILOT_VERSION"] and answers["TIMESYNC"] and answers["prearm bit"]
    assert answers["data stream POSITION"] and answers["guided MISSION_ITEM_INT"] == 0
    assert answers["FTP open @PARAM/param.pck"] == "ACK"


@pytest.mark.slow
@pytest.mark.udp
def test_sim_and_arducopter_answer_the_probe_alike(tmp_path: Path) -> None:
    require_sitl()
    real = _ask_sitl(tmp_path / "sitl")
    sim = _ask_sim()
    assert real["params"] > 1000 and sim["params"] >= 30
    differ = {k: (sim.get(k), real[k]) for k in real if k not in DIFFERENT_BY_DESIGN
              and sim.get(k) != real[k]}  # fmt: skip
    assert not differ, f"sim vs ArduCopter: {differ}"
