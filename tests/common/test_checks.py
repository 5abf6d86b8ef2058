"""The shared field checks (``ridsafe.common.checks``) and the config classes that use them:
each check passes its boundary cases, fails just beyond them and on non-finite numbers, and
names the field in what it raises."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import pytest

from ridsafe.common import checks
from ridsafe.common.clock import MonotonicClock, SimClock
from ridsafe.common.errors import ClockError, FieldValueError
from ridsafe.common.scenario import SpooferConfig
from ridsafe.companion.config import CompanionConfig
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.gcs.config import GcsConfig
from ridsafe.gcs.localisation.config import ImmConfig
from ridsafe.sim_backend.params import ControllerParams

NON_FINITE = (math.nan, math.inf, -math.inf)


@pytest.mark.parametrize("bad", NON_FINITE)
def test_finite(bad: float) -> None:
    checks.check_finite("x_m", 0.0)
    with pytest.raises(FieldValueError, match=r"^x_m: expected a finite number, got"):
        checks.check_finite("x_m", bad)
    with pytest.raises(ClockError, match="speed: expected a finite number"):
        checks.check_finite("speed", bad, error=lambda name, why: ClockError(f"{name}: {why}"))


def test_positive_and_non_negative() -> None:
    checks.check_positive("a", 1e-300)
    checks.check_non_negative("a", 0.0)
    with pytest.raises(FieldValueError, match=r"^a: must be finite and > 0, got 0\.0$"):
        checks.check_positive("a", 0.0)
    with pytest.raises(FieldValueError, match=r"^a: must be finite and >= 0, got -1e-09$"):
        checks.check_non_negative("a", -1e-9)
    for bad in NON_FINITE:
        with pytest.raises(FieldValueError, match="must be finite"):
            checks.check_positive("a", bad)
        with pytest.raises(FieldValueError, match="must be finite"):
            checks.check_non_negative("a", bad)


@dataclasses.dataclass
class Sample:
    gain: float = 1.0
    count: int = 2
    offset: float = 0.0
    enabled: bool = False  # bools are not numbers here
    label: str = "x"


def test_field_checks_by_name_and_over_every_numeric_field() -> None:
    checks.check_positive_fields(Sample(), "gain", "count", may_be_zero=("offset",))
    checks.check_numeric_fields_positive(Sample(), may_be_zero=("offset",))
    with pytest.raises(FieldValueError, match=r"^offset: must be finite and > 0"):
        checks.check_numeric_fields_positive(Sample())
    with pytest.raises(FieldValueError, match=r"^count: "):
        checks.check_numeric_fields_positive(Sample(count=0), may_be_zero=("offset",))
    with pytest.raises(FieldValueError, match=r"^gain: "):
        checks.check_positive_fields(Sample(gain=math.inf), "gain")


def test_at_least_interval_and_increasing() -> None:
    checks.check_at_least("n", 1, 1)
    with pytest.raises(FieldValueError, match=r"^n: expected >= 1, got 0$"):
        checks.check_at_least("n", 0, 1)
    checks.check_in_interval("v_m_s", 8.0, 0.0, 8.0)  # the upper bound is in
    checks.check_in_interval("t_s", 1e9, 0.0, math.inf)
    for bad in (0.0, 8.000001, *NON_FINITE):
        with pytest.raises(FieldValueError, match=r"^v_m_s: expected 0 < value <= 8, got"):
            checks.check_in_interval("v_m_s", bad, 0.0, 8.0)
    with pytest.raises(FieldValueError, match="expected 0 < value <= inf, got inf"):
        checks.check_in_interval("t_s", math.inf, 0.0, math.inf)
    checks.check_increasing("lo_m", -1.0, "hi_m", 1.0)
    for low, high in ((1.0, 1.0), (2.0, 1.0), (math.nan, 1.0), (0.0, math.inf)):
        with pytest.raises(FieldValueError, match=r"^lo_m: expected finite lo_m < hi_m, got"):
            checks.check_increasing("lo_m", low, "hi_m", high)


def test_vectors_probabilities_and_covariance_diagonals() -> None:
    checks.check_finite_vector("p_m", (1.0, -5.0, 5.0), 5.0, " m")
    with pytest.raises(FieldValueError, match=r"^p_m\[1\]: expected a finite value within"):
        checks.check_finite_vector("p_m", (1.0, -5.5, 0.0), 5.0, " m")
    with pytest.raises(FieldValueError, match=r"^p_m\[2\]: expected a finite value, got nan"):
        checks.check_finite_vector("p_m", (1.0, 2.0, math.nan))
    checks.check_probability_vector("mu", (0.25, 0.75))
    with pytest.raises(FieldValueError, match=r"^mu: sums to 0\.97, must be 1$"):
        checks.check_probability_vector("mu", (0.25, 0.72))
    with pytest.raises(FieldValueError, match=r"^mu\[0\]: expected a probability in \[0, 1\]"):
        checks.check_probability_vector("mu", (-0.25, 1.25))
    checks.check_covariance_diagonal("q", (0.0, 1.0), 2)
    with pytest.raises(FieldValueError, match=r"^q\[0\]: covariance diagonal must be > 0"):
        checks.check_covariance_diagonal("q", (0.0, 1.0), 2, strictly_positive=True)
    with pytest.raises(FieldValueError, match=r"^q: expected 3 values, got 2$"):
        checks.check_covariance_diagonal("q", (1.0, 1.0), 3)
    with pytest.raises(FieldValueError, match=r"^q\[1\]: covariance diagonal must be >= 0"):
        checks.check_covariance_diagonal("q", (1.0, math.nan), 2)


@pytest.mark.parametrize(
    ("build", "field"),
    [
        (lambda: GcsConfig(cycle_s=math.inf), "cycle_s"),
        (lambda: GcsConfig(warn_interval_s=-1.0), "warn_interval_s"),
        (lambda: GcsConfig(max_peers=0), "max_peers"),
        (lambda: GcsConfig(rssi_min_dbm=0.0, rssi_max_dbm=-10.0), "rssi_min_dbm"),
        (lambda: GcsConfig(max_distance_m=0.0), "max_distance_m"),
        (lambda: ImmConfig(gate_chi2=-1.0), "gate_chi2"),
        (lambda: ImmConfig(mu0=(0.5, 0.6)), "mu0"),
        (lambda: ImmConfig(r_cv_diag=(1.0, 0.0, 1.0)), r"r_cv_diag\[1\]"),
        (lambda: CompanionConfig(cruise_speed_m_s=0.0), "cruise_speed_m_s"),
        (lambda: CompanionConfig(lookahead_s=math.inf), "lookahead_s"),
        (lambda: PlannerConfig(d_safe_m=-5.0), "d_safe_m"),
        (lambda: PlannerConfig(right_turn_bias=-0.1), "right_turn_bias"),
        (lambda: ControllerParams(max_speed_m_s=math.nan), "max_speed_m_s"),
        (lambda: ControllerParams(vel_int_gain_z_1_s2=-1.0), "vel_int_gain_z_1_s2"),
        (
            lambda: SpooferConfig("RSAF800000666", (0, 0, 60), (1e6, 0, 60)),
            r"goal_enu_m\[0\]",
        ),
    ],
)
def test_the_config_classes_reject_through_the_shared_checks(
    build: Callable[[], object], field: str
) -> None:
    with pytest.raises(FieldValueError, match=f"^{field}: "):
        build()


def test_the_clocks_refuse_non_finite_numbers_with_their_own_error() -> None:
    with pytest.raises(ClockError, match=r"^speed: expected a finite number, got nan"):
        MonotonicClock(math.nan)
    with pytest.raises(ClockError, match=r"^start_s: expected a finite number"):
        SimClock(start_s=math.inf)
