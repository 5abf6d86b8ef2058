"""The world every app of one scenario agrees on: origin, clock epoch, aircraft, adversaries,
radio (the adversaries' configs: ``ridsafe.common.adversary``).

Positions are metres in the scenario's local ENU frame about ``origin`` (x east, y north,
z up above the origin's ellipsoid height). App-specific settings (the sim's rates and
ports, the GCS's filters, the planner's rewards) live in each app's own config section;
``ridsafe.tools.run.scenario`` puts the sections of one YAML file together.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from ridsafe.common.adversary import GhostConfig, SpooferConfig
from ridsafe.common.checks import check_cta2063_serial, check_finite_vector
from ridsafe.common.errors import FieldValueError
from ridsafe.common.frames import GeodeticOrigin

__all__ = [
    "AREA_LIMIT_M",
    "AircraftConfig",
    "GhostConfig",
    "RadioConfig",
    "Scenario",
    "SpooferConfig",
    "Vec3",
    "check_cta2063_serial",
    "cta2063_serial",
]

Vec3 = tuple[float, float, float]

AREA_LIMIT_M = 100_000.0


def cta2063_serial(manufacturer_code: str, serial: str) -> str:
    """Compose a CTA-2063-A serial number (validated)."""
    number = f"{manufacturer_code}{len(serial):X}{serial}"
    check_cta2063_serial("serial", number)
    return number


@dataclass(frozen=True)
class AircraftConfig:
    """One benign aircraft: where it starts on the ground and where it delivers."""

    serial: str
    start_enu_m: Vec3
    goal_enu_m: Vec3
    cruise_alt_m: float = 60.0
    tx_power_dbm: float | None = None  # None: the radio's default
    departure_s: float = 0.0  # sim time at which it may take off (depots launch in turn)

    def __post_init__(self) -> None:
        check_cta2063_serial("serial", self.serial)
        if not 0.0 <= self.departure_s <= 86_400.0:
            raise FieldValueError("departure_s", f"expected 0..86400 s, got {self.departure_s}")
        check_finite_vector("start_enu_m", self.start_enu_m, AREA_LIMIT_M, " m")
        check_finite_vector("goal_enu_m", self.goal_enu_m, AREA_LIMIT_M, " m")
        for name in ("start_enu_m", "goal_enu_m"):
            if getattr(self, name)[2] != 0.0:
                raise FieldValueError(
                    f"{name}[2]", "depots and delivery sites are on the ground: z = 0"
                )
        if not 5.0 <= self.cruise_alt_m <= 500.0:
            raise FieldValueError("cruise_alt_m", f"expected 5..500 m, got {self.cruise_alt_m}")


@dataclass(frozen=True)
class RadioConfig:
    """The RID radio channel (DESIGN.md section 6; the model: ``sim_backend/radio.py``).

    The defaults are free-space path loss at ``frequency_mhz`` with i.i.d. 1 dB log-normal
    shadowing, isotropic antennas and exact RSSI (the paper's channel). Each option below
    makes the channel wrong in one way a real 2.4 GHz air-to-air link is; its default keeps
    that part off. Sources at each field and in ``configs/urban.yaml``.
    """

    frequency_mhz: float = 2400.0
    tx_power_dbm: float = 20.0
    shadowing_sigma_db: float = 1.0
    sensitivity_dbm: float = -95.0
    packet_loss_probability: float = 0.0
    #: Log-distance exponent n: loss L1 + 10 n log10(d) (Rappaport eq. 4.68; 2 = free space).
    path_loss_exponent: float = 2.0
    #: Two-ray model over flat ground at z = 0 (Rappaport section 4.6), antennas at each
    #: aircraft's height plus ``antenna_height_m``.
    ground_reflection: bool = False
    antenna_height_m: float = 0.3
    #: 'dipole': a half-wave dipole along each aircraft's body z axis (Balanis eq. 4-84), its
    #: gain from the angle between that axis and the other aircraft, so attitude matters.
    antenna: Literal["isotropic", "dipole"] = "isotropic"
    #: Std of each receiver's fixed RSSI calibration offset (dB), drawn once per run.
    receiver_bias_sigma_db: float = 0.0
    #: Std of each transmitter's true power about its nominal (dB), drawn once per run.
    tx_power_sigma_db: float = 0.0
    #: > 0: shadowing is spatially correlated per link with correlation
    #: exp(-displacement / this) (Gudmundson, Electron. Lett. 27(23), 1991); 0: i.i.d. draws.
    shadowing_decorrelation_m: float = 0.0
    #: Small-scale fading per reception: 'rician' with factor ``rician_k_db``.
    fading: Literal["none", "rician"] = "none"
    rician_k_db: float = 6.0
    #: Reported RSSI rounded to this step (dB; 1 = whole dBm as real receivers report); 0 off.
    rssi_resolution_db: float = 0.0

    def __post_init__(self) -> None:
        if not 1.0 <= self.frequency_mhz <= 100_000.0:
            raise FieldValueError("frequency_mhz", f"expected 1..100000, got {self.frequency_mhz}")
        if not -30.0 <= self.tx_power_dbm <= 40.0:
            raise FieldValueError("tx_power_dbm", f"expected -30..40 dBm, got {self.tx_power_dbm}")
        for name in (
            "shadowing_sigma_db",
            "receiver_bias_sigma_db",
            "tx_power_sigma_db",
            "rssi_resolution_db",
        ):
            value = getattr(self, name)
            if not 0.0 <= value <= 20.0:
                raise FieldValueError(name, f"expected 0..20 dB, got {value}")
        if not 0.0 <= self.packet_loss_probability < 1.0:
            raise FieldValueError(
                "packet_loss_probability",
                f"expected 0 <= p < 1, got {self.packet_loss_probability}",
            )
        if not 1.0 <= self.path_loss_exponent <= 6.0:
            raise FieldValueError(
                "path_loss_exponent", f"expected 1..6, got {self.path_loss_exponent}"
            )
        if not 0.0 <= self.antenna_height_m <= 10.0:
            raise FieldValueError(
                "antenna_height_m", f"expected 0..10 m, got {self.antenna_height_m}"
            )
        if not 0.0 <= self.shadowing_decorrelation_m <= 10_000.0:
            raise FieldValueError(
                "shadowing_decorrelation_m",
                f"expected 0..10000 m, got {self.shadowing_decorrelation_m}",
            )
        if not -20.0 <= self.rician_k_db <= 40.0:
            raise FieldValueError("rician_k_db", f"expected -20..40 dB, got {self.rician_k_db}")
        if self.antenna not in ("isotropic", "dipole"):
            raise FieldValueError("antenna", f"expected isotropic or dipole, got {self.antenna!r}")
        if self.fading not in ("none", "rician"):
            raise FieldValueError("fading", f"expected none or rician, got {self.fading!r}")


@dataclass(frozen=True)
class Scenario:
    """What every app of one run agrees on.

    ``spoofer`` is the shorthand for ``spoofers`` with one entry (give one or the other);
    ``adversaries`` lists them all. System ids: benign aircraft 1..N, then the spoofers, then
    the ghosts (each ghost's transmitter is a vehicle of the sim that holds its position)."""

    origin: GeodeticOrigin
    aircraft: tuple[AircraftConfig, ...]
    spoofer: SpooferConfig | None = None
    radio: RadioConfig = RadioConfig()
    name: str = "scenario"
    seed: int = 0
    duration_s: float = 120.0
    # UNIX time at sim time 0 (RID timestamps, SYSTEM_TIME): fixed so runs are reproducible.
    start_unix_s: float = 1_767_268_800.0  # 2026-01-01T12:00:00Z
    spoofers: tuple[SpooferConfig, ...] = ()
    ghosts: tuple[GhostConfig, ...] = ()

    def __post_init__(self) -> None:
        if not self.aircraft:
            raise FieldValueError("aircraft", "expected at least one aircraft, got none")
        if self.spoofer is not None and self.spoofers:
            raise FieldValueError("spoofers", "give spoofer (one) or spoofers (a list), not both")
        serials = [a.serial for a in self.aircraft]
        serials += [s.serial for s in self.all_spoofers] + [g.serial for g in self.ghosts]
        duplicates = sorted({s for s in serials if serials.count(s) > 1})
        if duplicates:
            raise FieldValueError(
                "aircraft", f"serial numbers must be unique, repeated: {duplicates}"
            )
        benign = {a.serial for a in self.aircraft}
        for k, spoofer in enumerate(self.spoofers or ((self.spoofer,) if self.spoofer else ())):
            field = f"spoofers[{k}]" if self.spoofers else "spoofer"
            for part, target in (
                ("motion", spoofer.resolved_motion.target_serial),
                ("claim", spoofer.resolved_claim.target_serial),
            ):
                if target is not None and target not in benign:
                    raise FieldValueError(
                        f"{field}.{part}.target_serial",
                        f"{target!r} is not a benign aircraft of the scenario",
                    )
        if not 0.0 < self.duration_s <= 86_400.0:
            raise FieldValueError(
                "duration_s", f"expected 0 < duration <= 86400, got {self.duration_s}"
            )
        if self.seed < 0:
            raise FieldValueError("seed", f"expected a non-negative seed, got {self.seed}")

    @property
    def all_spoofers(self) -> tuple[SpooferConfig, ...]:
        """``spoofers``, or the one ``spoofer`` shorthand."""
        if self.spoofer is not None:
            return (self.spoofer,)
        return self.spoofers

    @property
    def first_spoofer_sysid(self) -> int:
        return len(self.aircraft) + 1

    @property
    def first_ghost_sysid(self) -> int:
        return len(self.aircraft) + len(self.all_spoofers) + 1

    @property
    def vehicle_count(self) -> int:
        """Benign aircraft 1..N, spoofers N+1..N+S, ghost transmitters after them."""
        return len(self.aircraft) + len(self.all_spoofers) + len(self.ghosts)

    def serial_of(self, sysid: int) -> str:
        return self._adversary_or_aircraft(sysid).serial

    def tx_power_dbm_of(self, sysid: int) -> float:
        """The transmit power of vehicle ``sysid`` (the mean power of a random one)."""
        entry = self._adversary_or_aircraft(sysid)
        if isinstance(entry, AircraftConfig):
            own = entry.tx_power_dbm
        elif entry.tx_power is not None:
            own = entry.tx_power.mean_power_dbm
        else:
            own = entry.tx_power_dbm if isinstance(entry, SpooferConfig) else None
        return self.radio.tx_power_dbm if own is None else own

    def _adversary_or_aircraft(self, sysid: int) -> AircraftConfig | SpooferConfig | GhostConfig:
        n, spoofers = len(self.aircraft), self.all_spoofers
        if 1 <= sysid <= n:
            return self.aircraft[sysid - 1]
        if n < sysid <= n + len(spoofers):
            return spoofers[sysid - n - 1]
        if n + len(spoofers) < sysid <= self.vehicle_count:
            return self.ghosts[sysid - n - len(spoofers) - 1]
        raise KeyError(f"no vehicle with system id {sysid} (have 1..{self.vehicle_count})")
