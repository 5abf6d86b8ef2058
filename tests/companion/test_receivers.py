"""RID receivers: where heard frames come from (transponder messages, recorded frames)."""

from __future__ import annotations

from ridsafe.common import messages as m
from ridsafe.common.heard import HeardRidFrame
from ridsafe.companion.receivers import RecordedFrames, RidReceiver, TransponderReceiver

SIM = int(m.RidTransport.SIMULATED)


def _report(dbm: float) -> m.RidFrameReport:
    return m.RidFrameReport(b"\x12" + bytes(24), dbm, b"RSAF800000001", SIM)


def test_the_transponder_receiver_stamps_each_frame_on_arrival_with_its_own_rssi() -> None:
    receiver: RidReceiver = TransponderReceiver()
    receiver.on_transponder(3.5, _report(-70.0))
    receiver.on_transponder(3.5, _report(-90.0))
    receiver.on_transponder(3.6, m.OdidArmStatus(0, ""))  # not a heard frame: counted
    heard = receiver.poll(3.6)
    assert heard == [
        HeardRidFrame(3.5, _report(-70.0)),
        HeardRidFrame(3.5, _report(-90.0)),
    ]
    assert receiver.poll(3.7) == []
    assert receiver.counters() == {"frames": 2, "other": 1}


def test_recorded_frames_come_out_when_the_clock_reaches_them_in_time_order() -> None:
    late, early = HeardRidFrame(2.0, _report(-80.0)), HeardRidFrame(1.0, _report(-60.0))
    receiver: RidReceiver = RecordedFrames([late, early])
    receiver.on_transponder(0.5, _report(-10.0))  # ignored: not this receiver's radio
    assert receiver.poll(0.9) == []
    assert receiver.poll(1.5) == [early]
    assert receiver.poll(5.0) == [late]
    assert receiver.counters() == {"released": 2, "waiting": 0}
