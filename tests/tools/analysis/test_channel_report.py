"""The report's channel section: each radio setting against issue 15's bar, and by how much it
misses.

Oracle: the bar's numbers worked by hand for a handful of made-up run records.
"""

from __future__ import annotations

from pathlib import Path

from ridsafe.tools.analysis.channel_report import channel_section, is_channel_sweep
from ridsafe.tools.analysis.sweep_results import RunRecord, SweepResults
from ridsafe.tools.sweep.plan import RunSpec

GOOD = {
    "containment_rate": 0.95,
    "rmse_m": 20.0,
    "false_alerts": 0,
    "goal_reached_fraction": 1.0,
    "nmac_benign_spoofer": 0,
    "detection_delay_s": 3.0,
}


def _record(
    sigma: float, density: int, planner: str, seed: int, **metrics: float | None
) -> RunRecord:
    spec = RunSpec(
        density,
        seed,
        planner,
        120.0,
        (("sigma", sigma),),
        (("scenario.radio.shadowing_sigma_db", sigma),),
    )
    return RunRecord(Path(f"r{seed}"), spec, {**GOOD, **metrics})


def _sweep(*records: RunRecord, calibrating: bool = False) -> SweepResults:
    return SweepResults(
        Path("s"), "robustness", "configs/robustness.yaml", records, (), 0, 0, calibrating
    )


def test_each_setting_meets_or_says_by_how_much_it_misses() -> None:
    records = [
        _record(1.0, 16, "aware", 0),
        _record(1.0, 16, "aware", 1),
        _record(1.0, 16, "trust-rid", 0, nmac_benign_spoofer=2),
        # sigma 4: containment and RMSE meet the 8-aircraft bar but not the 16-aircraft one,
        # delays 2, 4, 30 and one run without an alert
        *(
            _record(4.0, n, "aware", seed, containment_rate=0.87, rmse_m=50.0, detection_delay_s=d)
            for n in (8, 16)
            for seed, d in enumerate((2.0, 4.0, 30.0))
        ),
        _record(4.0, 16, "aware", 3, detection_delay_s=None, false_alerts=1),
        _record(4.0, 16, "trust-rid", 0, nmac_benign_spoofer=1),
        _record(4.0, 16, "trust-rid", 1, nmac_benign_spoofer=0),
    ]
    lines = channel_section([_sweep(*records)])
    rows = {
        (cells[1], cells[2]): line
        for line in lines
        if line.startswith("| robustness")
        for cells in [[c.strip() for c in line.split("|")]]
    }
    assert rows[("robustness [sigma=1.0]", "16")].endswith("| meets |")
    eight = rows[("robustness [sigma=4.0]", "8")]
    assert "| 4.0 / 24.8 / 30.0 |" in eight  # median, p90 (linear: 4 + 0.8 x 26), worst
    assert "delay p90 9.8 s over" in eight and "containment" not in eight and "RMSE" not in eight
    sixteen = rows[("robustness [sigma=4.0]", "16")]
    assert "(1 none)" in sixteen and "1 run(s) never alerted" in sixteen
    assert "false alerts 0.25/run" in sixteen  # 1 in 4 runs
    # containment (0.87 x 3 + 0.95) / 4 = 0.89, 0.01 short; RMSE (50 x 3 + 20) / 4 = 42.5
    assert "containment 0.010 short of 0.9" in sixteen and "RMSE 2 m over 40" in sixteen


def test_nmacs_against_the_bar_and_trust_rid() -> None:
    records = [
        _record(2.0, 16, "aware", 0, nmac_benign_spoofer=1),
        _record(2.0, 16, "aware", 1, nmac_benign_spoofer=0),
        _record(2.0, 16, "trust-rid", 0, nmac_benign_spoofer=2),
    ]
    (row,) = [line for line in channel_section([_sweep(*records)]) if line.startswith("| rob")]
    assert "NMAC 0.50 > 0.15" in row and "NMAC 0.50 > 0.2 x trust-RID 2.00" in row


def test_alerts_on_a_bystander_are_false_alerts_and_the_verdict_says_in_how_many_runs() -> None:
    records = [
        _record(1.0, 16, "aware", 0, bystander_count=1, bystanders_alerted=1, false_alerts=2),
        _record(1.0, 16, "aware", 1, bystander_count=1, bystanders_alerted=0),
        _record(1.0, 16, "aware", 2, bystander_count=1, bystanders_alerted=0, false_alerts=1),
    ]
    (row,) = [line for line in channel_section([_sweep(*records)]) if line.startswith("| rob")]
    assert "| 1.00 |" in row  # false alerts per run: (2 + 0 + 1) / 3
    assert "false alerts 1.00/run (a bystander alerted in 1 of 3 runs)" in row


def test_which_sweeps_are_channel_sweeps() -> None:
    plain = RunRecord(Path("r"), RunSpec(16, 0, "aware", 120.0), dict(GOOD))
    alpha = RunSpec(16, 0, "aware", 120.0, (("alpha", 0.1),), (("pipeline.region.alpha", 0.1),))
    assert not is_channel_sweep(_sweep(plain, RunRecord(Path("r"), alpha, dict(GOOD))))
    assert channel_section([_sweep(plain)]) == []
    assert is_channel_sweep(_sweep(plain, calibrating=True))  # e.g. configs/urban.yaml
    assert is_channel_sweep(_sweep(_record(1.0, 16, "aware", 0)))
