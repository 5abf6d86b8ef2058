"""The world every app of one scenario agrees on: origin, clock epoch, aircraft, spoofer, radio.

Positions are metres in the scenario's local ENU frame about ``origin`` (x east, y north,
z up above the origin's ellipsoid height). App-specific settings (the sim's rates and
ports, the GCS's filters, the planner's rewards) live in each app's own config section;
``ridsafe.tools.run.scenario`` puts the sections of one YAML file together.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

from ridsafe.common.checks import check_finite_vector
from ridsafe.common.errors import FieldValueError
from ridsafe.common.frames import GeodeticOrigin

Vec3 = tuple[float, float, float]

# CTA-2063-A serial number: 4-character manufacturer code, one length character
# ('1'-'9', 'A'-'F' for 1-15) and the manufacturer's serial of that length. Digits and
# upper-case letters except O and I.
_CTA_CHARS = "0123456789ABCDEFGHJKLMNPQRSTUVWXYZ"
_CTA_RE = re.compile(rf"^[{_CTA_CHARS}]{{4}}[1-9A-F][{_CTA_CHARS}]{{1,15}}$")
AREA_LIMIT_M = 100_000.0


def cta2063_serial(manufacturer_code: str, serial: str) -> str:
    """Compose a CTA-2063-A serial number (validated)."""
    number = f"{manufacturer_code}{len(serial):X}{serial}"
    check_cta2063_serial("serial", number)
    return number


def check_cta2063_serial(field: str, number: str) -> None:
    if not _CTA_RE.match(number) or int(number[4], 16) != len(number) - 5:
        raise FieldValueError(
            field,
            f"expected a CTA-2063-A serial (4-char maker code, length char, serial), "
            f"got {number!r}",
        )


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
class SpooferConfig:
    """The spoofer: flies a straight line at constant speed, avoids nobody, and broadcasts
    its true position plus a constant offset."""

    serial: str
    start_enu_m: Vec3
    goal_enu_m: Vec3
    speed_m_s: float = 7.0
    offset_enu_m: Vec3 = (50.0, 50.0, 0.0)
    tx_power_dbm: float | None = None

    def __post_init__(self) -> None:
        check_cta2063_serial("serial", self.serial)
        check_finite_vector("start_enu_m", self.start_enu_m, AREA_LIMIT_M, " m")
        check_finite_vector("goal_enu_m", self.goal_enu_m, AREA_LIMIT_M, " m")
        check_finite_vector("offset_enu_m", self.offset_enu_m, 10_000.0, " m")
        if not 0.0 < self.speed_m_s <= 8.0:
            raise FieldValueError("speed_m_s", f"expected 0 < speed <= 8 m/s, got {self.speed_m_s}")
        if self.start_enu_m[2] < 5.0:
            raise FieldValueError("start_enu_m[2]", "the spoofer starts airborne: z >= 5 m")


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
    """What every app of one run agrees on."""

    origin: GeodeticOrigin
    aircraft: tuple[AircraftConfig, ...]
    spoofer: SpooferConfig | None = None
    radio: RadioConfig = RadioConfig()
    name: str = "scenario"
    seed: int = 0
    duration_s: float = 120.0
    # UNIX time at sim time 0 (RID timestamps, SYSTEM_TIME): fixed so runs are reproducible.
    start_unix_s: float = 1_767_268_800.0  # 2026-01-01T12:00:00Z

    def __post_init__(self) -> None:
        if not self.aircraft:
            raise FieldValueError("aircraft", "expected at least one aircraft, got none")
        serials = [a.serial for a in self.aircraft]
        if self.spoofer is not None:
            serials.append(self.spoofer.serial)
        duplicates = sorted({s for s in serials if serials.count(s) > 1})
        if duplicates:
            raise FieldValueError(
                "aircraft", f"serial numbers must be unique, repeated: {duplicates}"
            )
        if not 0.0 < self.duration_s <= 86_400.0:
            raise FieldValueError(
                "duration_s", f"expected 0 < duration <= 86400, got {self.duration_s}"
            )
        if self.seed < 0:
            raise FieldValueError("seed", f"expected a non-negative seed, got {self.seed}")

    @property
    def vehicle_count(self) -> int:
        """Benign aircraft are vehicles 1..N, the spoofer (if any) is vehicle N + 1."""
        return len(self.aircraft) + (0 if self.spoofer is None else 1)

    def serial_of(self, sysid: int) -> str:
        if 1 <= sysid <= len(self.aircraft):
            return self.aircraft[sysid - 1].serial
        if self.spoofer is not None and sysid == len(self.aircraft) + 1:
            return self.spoofer.serial
        raise KeyError(f"no vehicle with system id {sysid} (have 1..{self.vehicle_count})")

    def tx_power_dbm_of(self, sysid: int) -> float:
        if 1 <= sysid <= len(self.aircraft):
            own = self.aircraft[sysid - 1].tx_power_dbm
        elif self.spoofer is not None and sysid == len(self.aircraft) + 1:
            own = self.spoofer.tx_power_dbm
        else:
            raise KeyError(f"no vehicle with system id {sysid}")
        return self.radio.tx_power_dbm if own is None else own
