"""Configuration of the FastMDP-style planners (``aware`` and ``trust-rid``).

One frozen dataclass, :class:`PlannerConfig`, loaded from the ``planner:`` section of a scenario
YAML file with :func:`ridsafe.common.config.from_mapping`. The defaults are the paper's reward
table (section 5, Table "Reward Function for Each Aircraft") and the authors' action set; where
the paper is silent the default is ours, and the field's comment says so and why:

=============================  ===========================================================
paper (Table 4)                goal +200 decay 0.999; benign conflict -(100 t + 500) decay
                               0.97 within d_safe; spoofer unsafe region -1000 decay 0.97
authors' code (REFERENCE.md)   16 headings + goal, goal +/-15, +/-30 deg; speeds 8/6/4/2/0;
                               13 flight-path angles +/-{20, 16.2, 12.7, 9.3, 6.0, 2.9, 0}
                               deg; 20 x 0.5 s = 10 s rollouts; target ~1 s ahead; replan
                               every 0.5 s; goal reached within 10 m
ours, where the paper is       d_safe = 100 m (twice the 50 m NMAC radius; it is also the
silent                         benign term's gating radius L)
                               t = seconds the rollout has already spent within d_safe of
                               that aircraft (a lingering conflict costs more; without the
                               growth the closed loop has ~10x the benign NMACs)
                               region distance = sqrt(lambda_min(P)) (sqrt(m) - sqrt(chi2)),
                               a lower bound of the Euclidean distance to the ellipsoid
                               (:mod:`ridsafe.companion.value` eq. 4), gated at 75 m
                               shield: no rollout sample within 30 m of the ellipsoid (grown
                               by 1 m/s x prediction time); an aircraft already closer may
                               not close in; 3 climb/descend/hover actions; 10 s extension
                               toward the goal (:mod:`ridsafe.companion.planner_eval`)
                               envelope = the sim autopilot's limits; altitude 10-120 m
                               setpoint = rollout position 0.25 s and velocity 1 s ahead;
                               goal itself within 40 m when unhindered (the point over
                               it at the aircraft's height where any height arrives)
=============================  ===========================================================

The margins were chosen on ``bench/planner_closed_loop.py`` (30 seeds, 16 aircraft): a 30 m
shield margin keeps benign-spoofer NMACs at 0.03 per run with an honest region covariance and
0.20 when the GCS is 1.5x overconfident (containment 0.68), while >= 95 % of the aircraft
reach their goals in 120 s; 50 m gives 0.00 / 0.07 NMACs but about 1 % fewer arrivals.

Why the setpoint takes the position and the velocity at different lead times: the sim's
autopilot (``ridsafe.sim_backend.controller``) holds a position target fixed and adds the
velocity as feed-forward, v_cmd = v* + k_p (p* - p). A position that leads the aircraft by L
seconds adds about k_p |v| L, which at 8 m/s outweighs any velocity change the rollout asks for
within L: an aircraft told to turn back keeps flying away. With the position half a replan
period ahead (0.25 s) the mean position error over the 0.5 s hold is zero, so the aircraft
flies the commanded velocity, and the velocity 1 s ahead (the authors' lead) gives the cascade
a step of at most ``accel_m_s2`` x 1 s. ArduPilot's GUIDED mode moves the position target
along the velocity instead; there the same setpoint tracks the rollout as well.

Signs follow the paper: the goal reward is positive, hazard rewards are negative.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

from ridsafe.common.checks import check_positive_fields
from ridsafe.common.errors import FieldValueError

__all__ = ["GRAVITY_M_S2", "ArrivalAction", "PlannerConfig"]

GRAVITY_M_S2 = 9.80665

_PAPER_FPA_DEG = (0.0, 2.9, -2.9, 6.0, -6.0, 9.3, -9.3, 12.7, -12.7, 16.2, -16.2, 20.0, -20.0)


class ArrivalAction(enum.Enum):
    """What an aircraft does once within ``arrival_radius_m`` of its goal."""

    HOVER = "hover"  # hold the goal point
    LAND = "land"  # descend above the goal to ``ground_down_m``


@dataclass(frozen=True)
class PlannerConfig:
    """Rewards, action set, rollouts, envelope, goal handling and the progress watchdog."""

    # -- rewards: V_i(s) = 1[d_i < L_i] R_i / (1 - gamma_i^2) gamma_i^d_i (paper Table 4) --------
    goal_reward: float = 200.0
    goal_decay: float = 0.999
    goal_gate_m: float = 10_000.0  # ours: the goal attracts from anywhere in the area
    goal_vertical_weight: float = 1.0  # d_goal = |(dn, de, w dd)|; 1 = the paper's Euclidean
    benign_reward_base: float = -500.0  # R = benign_reward_base + benign_reward_per_s * t
    benign_reward_per_s: float = -100.0  # t: rollout seconds already spent within d_safe (ours)
    benign_decay: float = 0.97
    d_safe_m: float = 100.0  # ours: gating radius of the benign term, 2 x NMAC radius
    # ours: the benign term's distance is |(dn, de, w dd)|; 1 = the paper's Euclidean. With
    # w > 1 an aircraft w x dh above or below counts as that far away, so traffic in altitude
    # layers (family.cruise_alt_by_heading) passes over other layers without a conflict; the
    # reported separation (and the approach check) stays Euclidean. It also weakens the term
    # near the NMAC radius (35 m below counts as 70 m with w = 2): with layers 55 m apart the
    # benign NMACs doubled at 32 aircraft (docs/results/dense_traffic.md).
    benign_vertical_weight: float = 1.0
    region_reward: float = -1000.0
    region_decay: float = 0.97
    region_gate_m: float = 75.0  # ours: the region term vanishes this far from its surface
    hazard_mean_weight: float = 0.0  # H = worst over the rollout + w * mean over the rollout
    # -- shielding against unsafe regions (ours) --------------------------------------------------
    region_margin_m: float = 30.0  # a rollout within this of the ellipsoid "enters" it
    region_velocity_std_m_s: float = 1.0  # P(tau) = P + (sigma_v tau)^2 I for prediction time tau
    # -- actions (authors' set; the goal-relative headings are recomputed every decision) -------
    n_headings: int = 16
    goal_heading_offsets_deg: tuple[float, ...] = (0.0, 15.0, -15.0, 30.0, -30.0)
    speeds_m_s: tuple[float, ...] = (8.0, 6.0, 4.0, 2.0)  # plus climb, descend, hover
    flight_path_angles_deg: tuple[float, ...] = _PAPER_FPA_DEG  # > 0 climbs
    right_turn_bias: float = 50.0  # ours: value bonus * sin(turn right of goal); breaks ties
    # -- rollouts ---------------------------------------------------------------------------------
    horizon_s: float = 10.0
    n_samples: int = 20  # value sampled at horizon_s * k / n_samples, k = 1..n_samples
    # Ours: each rollout is extended by extension_s of flight straight at the goal at max
    # speed, halted where it would enter an unsafe region; the goal term is averaged over both
    # (so waiting for a region to pass beats running alongside it). 0 samples: no extension.
    extension_s: float = 10.0
    extension_samples: int = 10
    accel_m_s2: float = 2.5  # velocity ramp of the rollout model (ours; <= g tan(max_tilt))
    replan_period_s: float = 0.5
    # The setpoint is the chosen rollout's state a short time ahead: its position at
    # target_lead_s and its velocity at velocity_lead_s (ours, see the module docstring).
    target_lead_s: float = 0.25
    velocity_lead_s: float = 1.0
    # -- flight envelope (the sim autopilot's ControllerParams) ---------------------------------
    max_speed_m_s: float = 8.0
    max_climb_m_s: float = 2.5
    max_descent_m_s: float = 1.5
    max_tilt_deg: float = 30.0
    min_altitude_m: float = 10.0  # ours: no rollout descends below this (unless already lower)
    max_altitude_m: float = 120.0  # ours: 400 ft, the small-UAS ceiling
    # -- inputs -----------------------------------------------------------------------------------
    neighbour_max_age_s: float = 5.0  # RID older than this is ignored (RID runs at 1 Hz)
    # -- goal handling ----------------------------------------------------------------------------
    approach_radius_m: float = 40.0  # ours: closer than this and unhindered, fly at the goal
    # ours: ... or when others are about but none comes closer than this while the aircraft
    # stays here (held actions cannot place it within 10 m of the goal among traffic)
    approach_min_separation_m: float = 60.0
    # ours: where the goal counts as reached at any height (PlannerInput.goal_any_height), the
    # approach keeps the aircraft's height: within approach_radius_m horizontally it brakes
    # onto the point over the goal, and the mission's descent starts there. An aircraft that
    # climbed over traffic and reached its site 40 m above its cruise level no longer waits
    # to sink to that level among the aircraft landing nearby before it may arrive.
    approach_level: bool = True
    # ours: where the goal is the ground under the site and the aircraft descends to it over
    # the site (PlannerInput.descend_to_goal), the approach radius is horizontal too: over
    # its site, hovering clear and no neighbour predicted within approach_min_separation_m of
    # the column down to the goal, the setpoint is the goal itself and the autopilot descends
    # straight onto it. Otherwise, 40-70 m above the site (beyond approach_radius_m in 3-D)
    # it chose among held actions and drifted 30-60 m off its site keeping d_safe from
    # aircraft landing at sites nearby (docs/results/dense_traffic.md).
    approach_descent: bool = True
    arrival_radius_m: float = 10.0
    on_arrival: ArrivalAction = ArrivalAction.HOVER
    ground_down_m: float = 0.0  # NED down of the ground at the goal (home at ground level)
    stuck_after_s: float = 30.0  # no progress for this long -> status STUCK (logged)
    stuck_progress_m: float = 10.0  # progress = getting this much closer than ever before

    def __post_init__(self) -> None:
        self._check_rewards()
        self._check_actions()
        self._check_rollouts()
        self._check_envelope()

    def _check_rewards(self) -> None:
        check_positive_fields(
            self, "goal_reward", "goal_gate_m", "goal_vertical_weight", "d_safe_m", "region_gate_m"
        )
        if not self.benign_vertical_weight >= 1.0:  # the neighbour culling assumes >= 1
            raise FieldValueError(
                "benign_vertical_weight", f"must be >= 1, got {self.benign_vertical_weight}"
            )
        check_positive_fields(
            self, "arrival_radius_m", "approach_radius_m", "stuck_after_s", "stuck_progress_m"
        )
        check_positive_fields(
            self, "neighbour_max_age_s", "region_margin_m", "approach_min_separation_m"
        )
        check_positive_fields(
            self, may_be_zero=("region_velocity_std_m_s", "right_turn_bias", "hazard_mean_weight")
        )
        for name in ("benign_reward_base", "region_reward"):
            if not getattr(self, name) < 0.0:
                raise FieldValueError(
                    name, f"a hazard reward must be < 0, got {getattr(self, name)}"
                )
        if not self.benign_reward_per_s <= 0.0:
            raise FieldValueError(
                "benign_reward_per_s",
                f"must be <= 0 (longer conflicts cost more), got {self.benign_reward_per_s}",
            )
        if self.approach_min_separation_m > self.d_safe_m:
            raise FieldValueError(
                "approach_min_separation_m",
                f"must be <= d_safe_m={self.d_safe_m} (the planner predicts separations only "
                f"within d_safe), got {self.approach_min_separation_m}",
            )
        for name in ("goal_decay", "benign_decay", "region_decay"):
            value = getattr(self, name)
            if not 0.0 < value < 1.0:
                raise FieldValueError(name, f"a decay must lie in (0, 1), got {value}")

    def _check_actions(self) -> None:
        if self.n_headings < 1:
            raise FieldValueError("n_headings", f"must be >= 1, got {self.n_headings}")
        for name in ("speeds_m_s", "flight_path_angles_deg"):
            if not getattr(self, name):
                raise FieldValueError(name, "must not be empty")
        for i, speed in enumerate(self.speeds_m_s):
            if not 0.0 < speed <= self.max_speed_m_s:
                raise FieldValueError(
                    f"speeds_m_s[{i}]",
                    f"must lie in (0, max_speed_m_s={self.max_speed_m_s}], got {speed}",
                )
        for i, fpa in enumerate(self.flight_path_angles_deg):
            if not -90.0 < fpa < 90.0:
                raise FieldValueError(
                    f"flight_path_angles_deg[{i}]", f"must lie in (-90, 90), got {fpa}"
                )
        for i, offset in enumerate(self.goal_heading_offsets_deg):
            if not -180.0 <= offset <= 180.0:
                raise FieldValueError(
                    f"goal_heading_offsets_deg[{i}]", f"must lie in [-180, 180], got {offset}"
                )

    def _check_rollouts(self) -> None:
        check_positive_fields(self, "horizon_s", "accel_m_s2", "replan_period_s", "velocity_lead_s")
        check_positive_fields(self, may_be_zero=("target_lead_s",))
        if self.n_samples < 1:
            raise FieldValueError("n_samples", f"must be >= 1, got {self.n_samples}")
        if self.extension_samples < 0:
            raise FieldValueError(
                "extension_samples", f"must be >= 0, got {self.extension_samples}"
            )
        if self.extension_samples > 0:
            check_positive_fields(self, "extension_s")
        for name in ("target_lead_s", "velocity_lead_s"):
            if getattr(self, name) > self.horizon_s:
                raise FieldValueError(
                    name, f"must be <= horizon_s={self.horizon_s}, got {getattr(self, name)}"
                )
        a_max = GRAVITY_M_S2 * math.tan(math.radians(self.max_tilt_deg))
        if self.accel_m_s2 > a_max:
            raise FieldValueError(
                "accel_m_s2",
                f"must be <= g tan(max_tilt_deg) = {a_max:.2f} m/s^2 to be flyable, "
                f"got {self.accel_m_s2}",
            )

    def _check_envelope(self) -> None:
        check_positive_fields(self, "max_speed_m_s", "max_climb_m_s", "max_descent_m_s")
        if not 0.0 < self.max_tilt_deg < 90.0:
            raise FieldValueError("max_tilt_deg", f"must lie in (0, 90), got {self.max_tilt_deg}")
        if not 0.0 <= self.min_altitude_m < self.max_altitude_m:
            raise FieldValueError(
                "min_altitude_m",
                f"must satisfy 0 <= min_altitude_m < max_altitude_m={self.max_altitude_m}, "
                f"got {self.min_altitude_m}",
            )
        if not math.isfinite(self.ground_down_m):
            raise FieldValueError("ground_down_m", f"must be finite, got {self.ground_down_m}")

    @property
    def sample_times_s(self) -> tuple[float, ...]:
        """Rollout sample times tau_k = horizon_s k / n_samples, k = 1..n_samples."""
        return tuple(self.horizon_s * k / self.n_samples for k in range(1, self.n_samples + 1))

    @property
    def extension_times_s(self) -> tuple[float, ...]:
        """Times of the extension's samples: horizon_s + extension_s k / extension_samples."""
        n = self.extension_samples
        return tuple(self.horizon_s + self.extension_s * k / n for k in range(1, n + 1))

    @property
    def n_actions(self) -> int:
        """Actions per decision: (absolute + goal-relative headings) x speeds x angles, then
        climb, descend and hover."""
        headings = self.n_headings + len(self.goal_heading_offsets_deg)
        return headings * len(self.speeds_m_s) * len(self.flight_path_angles_deg) + 3
