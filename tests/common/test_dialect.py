"""The committed dialect module is exactly what mavgen makes of the committed XML."""

from __future__ import annotations

from pathlib import Path

from ridsafe.common.dialect import generate
from ridsafe.common.dialect import ridsafe_v20 as mav


def test_committed_module_equals_a_fresh_mavgen_generation(tmp_path: Path) -> None:
    fresh = tmp_path / "fresh.py"
    generate.generate(fresh)
    committed = generate.GENERATED_MODULE.read_bytes()
    assert fresh.read_bytes() == committed, (
        "ridsafe_v20.py is stale: run `python -m ridsafe.common.dialect.generate`"
    )


def test_custom_messages_live_in_the_reserved_id_range() -> None:
    ours = [name for name in dir(mav) if name.startswith("MAVLINK_MSG_ID_RIDSAFE_")]
    assert len(ours) >= 6
    assert all(61000 <= getattr(mav, name) <= 61099 for name in ours)


def test_dialect_keeps_open_drone_id_ids_from_common() -> None:
    assert mav.MAVLINK_MSG_ID_OPEN_DRONE_ID_LOCATION == 12901
    assert mav.MAVLINK_MSG_ID_OPEN_DRONE_ID_MESSAGE_PACK == 12915
