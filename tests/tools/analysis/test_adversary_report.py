"""The report's adversary section: each attack cell against issue 16's bar, and the ghosts'
cost as delivered fraction over the control cell ``line`` on the same seeds.

Oracle: the bar's numbers worked by hand for a handful of made-up run records.
"""

from __future__ import annotations

from pathlib import Path

from ridsafe.tools.analysis.adversary_report import adversary_section
from ridsafe.tools.analysis.sweep_results import RunRecord, SweepResults
from ridsafe.tools.sweep.plan import RunSpec


def _record(cell: str, planner: str, seed: int, **metrics: float) -> RunRecord:
    spec = RunSpec(16, seed, planner, 120.0, (("adversary", cell),), ())
    return RunRecord(Path(f"r{seed}"), spec, dict(metrics))


def _sweep(*records: RunRecord) -> SweepResults:
    return SweepResults(Path("s"), "adversaries", "configs/adversaries.yaml", records, (), 0, 0)


def test_each_cell_meets_or_says_by_how_much_it_misses() -> None:
    ok = {"containment_rate": 0.95, "false_alerts": 0, "goal_reached_fraction": 1.0}
    control = {"benign_path_length_m": 1000.0, "mean_arrival_time_s": 60.0}
    records = [
        _record("line", "aware", 0, nmac_benign_spoofer=0, **ok, **control),
        _record("line", "aware", 1, nmac_benign_spoofer=0, **ok, **control),
        _record("line", "trust-rid", 0, nmac_benign_spoofer=1, **ok),
        _record("line", "trust-rid", 1, nmac_benign_spoofer=2, **ok),
        _record("orbit", "aware", 0, nmac_benign_spoofer=1, **{**ok, "containment_rate": 0.8}),
        _record("orbit", "trust-rid", 0, nmac_benign_spoofer=2, **ok),
        _record("two-ghosts", "aware", 0, nmac_benign_spoofer=0, ghosts_alerted=2,
                ghost_on_ground_fraction=0.6, aircraft_held_by_ghosts=1, pad_hold_s_ghosts=12.0,
                benign_path_length_m=1100.0, mean_arrival_time_s=62.0,
                **{**ok, "goal_reached_fraction": 0.9}),
        _record("two-ghosts", "aware", 1, nmac_benign_spoofer=0, ghosts_alerted=2,
                ghost_on_ground_fraction=0.8, aircraft_held_by_ghosts=0, pad_hold_s_ghosts=0.0,
                benign_path_length_m=1100.0, mean_arrival_time_s=64.0, **ok),
        _record("two-ghosts", "trust-rid", 0, nmac_benign_spoofer=0, ghosts_alerted=2,
                **{**ok, "goal_reached_fraction": 0.5}),
    ]  # fmt: skip
    lines = adversary_section([_sweep(*records)])
    rows: dict[str, str] = {}
    for line in lines:  # the first table's row of each cell (the ghost table comes after)
        if line.startswith("| `"):
            rows.setdefault(line.split("|")[1].strip(), line)
    assert rows["`line`"].endswith("| meets |")
    orbit = rows["`orbit`"]
    assert "NMAC 1.00 > 0.15" in orbit and "NMAC 1.00 > 0.2 x trust-RID 2.00" in orbit
    assert "containment 0.80 < 0.9" in orbit
    ghosts = rows["`two-ghosts`"]
    assert "| 0.950 | 0.500 |" in ghosts  # (0.9 + 1.0) / 2 of line's; trust-RID 0.5 / 1.0
    assert "deliveries 5.0 % lost to ghosts" in ghosts
    assert "Spoofers taken for a radio on the ground" not in "".join(lines)  # no run says
    ghost_rows = [line for line in lines if line.startswith("| `two-ghosts`") and line != ghosts]
    assert ghost_rows == [
        "| `two-ghosts` | 16 | n/a | 0.70 | n/a | 0.50 | 6.0 | +10.0 % / n/a | +3.0 / n/a |"
    ]  # paths (1100 + 1100) / (1000 + 1000); arrivals ((62 - 60) + (64 - 60)) / 2


def test_a_spoofer_taken_for_a_radio_on_the_ground_is_named() -> None:
    records = [
        _record("orbit", "aware", 3, spoofer_regions_on_ground=12),
        _record("orbit", "aware", 4, spoofer_regions_on_ground=0),
        _record("line", "aware", 3, spoofer_regions_on_ground=0),
    ]
    text = "\n".join(adversary_section([_sweep(*records)]))
    assert "(their region sent flagged ON_GROUND): in 1 of 3 runs: `orbit` 16 aware seed 3." in text


def test_no_section_without_an_adversary_axis() -> None:
    spec = RunSpec(16, 0, "aware", 120.0)
    assert adversary_section([_sweep(RunRecord(Path("r"), spec, {}))]) == []
