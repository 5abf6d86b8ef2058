"""Tests of the MCAP recorder, its reader and merger, and the derived Foxglove channels.

Files are real MCAP files, read back with the ``mcap`` library's own reader where the test is
about the file format, and with ``read_records`` where it is about what the project reads.
"""

from __future__ import annotations

import json
import logging
import math
import shutil
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from numpy.typing import NDArray
from scipy.spatial.transform import Rotation

from ridsafe.common import topics
from ridsafe.common.frames import GeodeticOrigin, enu_to_geodetic
from ridsafe.tools import foxglove
from ridsafe.tools.recorder import (
    METADATA_NAME,
    LogReadError,
    McapRecorder,
    RecorderError,
    merge_parts,
    read_records,
)

FloatArray = NDArray[np.float64]
ORIGIN = {"lat_deg": 36.1447, "lon_deg": -86.8027, "alt_m": 180.0}
CHI2_95 = 7.814727903251178


def cycle(k: int) -> dict[str, Any]:
    return {"compute_ms": 0.5 + k, "n_observations": k, "n_transmissions": 2, "n_tracks": 1}


def raw_messages(path: Path) -> list[dict[str, Any]]:
    """Every message of a complete file, read with the mcap library's own (seeking) reader."""
    out = []
    with open(path, "rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            out.append(
                {
                    "topic": channel.topic,
                    "message_encoding": channel.message_encoding,
                    "schema_name": schema.name if schema else None,
                    "schema_encoding": schema.encoding if schema else None,
                    "schema": json.loads(schema.data) if schema else None,
                    "log_time": message.log_time,
                    "publish_time": message.publish_time,
                    "data": json.loads(message.data, parse_constant=_reject_constant),
                }
            )
    return out


def _reject_constant(name: str) -> Any:
    raise AssertionError(f"invalid JSON constant {name} in the log")


def write_cycles(path: Path, count: int, **options: Any) -> list[tuple[str, float, Any]]:
    logged = []
    with McapRecorder(path, **options) as recorder:
        for k in range(count):
            t_s = 0.25 * k
            recorder.log(topics.GCS_CYCLE, t_s, cycle(k))
            logged.append((topics.GCS_CYCLE, t_s, {"t_s": t_s, **cycle(k)}))
    return logged


def truncated_copy(path: Path, out: Path, size: int) -> Path:
    shutil.copyfile(path, out)
    with open(out, "r+b") as stream:
        stream.truncate(size)
    return out


# --------------------------------------------------------------------------------------------
# Round trip


def test_round_trip_through_a_real_mcap_file(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    decision = {
        "sysid": np.int64(3),
        "planner": "spoofing_aware ✈",
        "status": "cruise",
        "target_p_ned_m": np.array([1.5, -2.25, -60.0]),
        "target_v_ned_m_s": (1.0, 0.0, 0.0),
        "target_lat_deg": 36.14471234567,
        "target_lon_deg": -86.80271234567,
        "target_alt_m": np.float32(240.5),
        "compute_ms": 0.8125,
        "n_neighbours": 4,
        "n_regions": 0,
    }
    with caplog.at_level(logging.WARNING), McapRecorder(path, foxglove=False) as recorder:
        recorder.log(topics.GCS_CYCLE, 0.25, cycle(1))
        recorder.log(topics.DECISIONS, 0.5, decision)
        recorder.log("/custom/thing", 0.75, {"t_s": 99.0, "x": [1, 2]})  # its own t_s
        recorder.log("/custom/thing", 1.0, {})
        recorder.log(topics.GCS_CYCLE, 1.25, cycle(2))
    assert "/custom/thing" in caplog.text  # unknown topic: one warning
    assert caplog.text.count("/custom/thing: not in") == 1

    messages = raw_messages(path)
    assert [m["topic"] for m in messages] == [
        topics.GCS_CYCLE,
        topics.DECISIONS,
        "/custom/thing",
        "/custom/thing",
        topics.GCS_CYCLE,
    ]
    for m in messages:
        assert m["message_encoding"] == "json"
        assert m["schema_encoding"] == "jsonschema"
        assert m["log_time"] == m["publish_time"]
    assert [m["log_time"] for m in messages] == [
        250_000_000,
        500_000_000,
        750_000_000,
        1_000_000_000,
        1_250_000_000,
    ]
    assert messages[0]["schema"] == topics.schema(topics.GCS_CYCLE)
    assert messages[0]["schema_name"] == topics.GCS_CYCLE
    assert messages[2]["schema"] == {"title": "/custom/thing", "type": "object"}
    assert messages[0]["data"] == {"t_s": 0.25, **cycle(1)}
    assert next(iter(messages[0]["data"])) == "t_s"
    assert messages[1]["data"] == {
        "t_s": 0.5,
        **decision,
        "sysid": 3,
        "target_p_ned_m": [1.5, -2.25, -60.0],
        "target_v_ned_m_s": [1.0, 0.0, 0.0],
        "target_alt_m": 240.5,
    }
    assert messages[2]["data"] == {"t_s": 99.0, "x": [1, 2]}
    assert messages[3]["data"] == {"t_s": 1.0}
    # one channel per topic
    with open(path, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    assert sorted(c.topic for c in summary.channels.values()) == sorted(
        [topics.GCS_CYCLE, topics.DECISIONS, "/custom/thing"]
    )
    assert summary.statistics.message_count == 5


def test_read_records_returns_what_was_logged(tmp_path: Path) -> None:
    logged = write_cycles(tmp_path / "run.mcap", 50)
    assert list(read_records(tmp_path / "run.mcap")) == logged
    assert list(read_records(tmp_path / "run.mcap", topics=["/nothing"])) == []


def test_non_finite_numbers_become_null_and_are_counted(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    track = {"uas_id": "X", "p_enu_m": [1.0, math.nan, 2.0], "cov_enu_m2": [[math.inf]]}
    with caplog.at_level(logging.WARNING), McapRecorder(path) as recorder:
        recorder.log(topics.TRACKS, 1.0, track)
        recorder.log(topics.TRACKS, 2.0, {**track, "items": [{"v": -math.inf}, {"v": 1.0}]})
        counts = recorder.nonfinite_counts
    assert counts == {
        "/gcs/tracks:p_enu_m[]": 2,
        "/gcs/tracks:cov_enu_m2[][]": 2,
        "/gcs/tracks:items[].v": 1,
    }
    assert caplog.text.count("/gcs/tracks:p_enu_m[]") == 1  # warned once per field
    records = [r for _topic, _t, r in read_records(path)]
    assert records[0] == {
        "t_s": 1.0,
        "uas_id": "X",
        "p_enu_m": [1.0, None, 2.0],
        "cov_enu_m2": [[None]],
    }
    assert records[1]["items"] == [{"v": None}, {"v": 1.0}]
    raw_messages(path)  # strict JSON parse: no NaN / Infinity constants anywhere
    with open(path, "rb") as stream:
        (metadata,) = [m for m in make_reader(stream).iter_metadata() if m.name == METADATA_NAME]
    assert json.loads(metadata.metadata["nonfinite_nulled"]) == counts


def test_unserialisable_value_is_an_error_naming_topic_and_field(tmp_path: Path) -> None:
    with (
        McapRecorder(tmp_path / "run.mcap") as recorder,
        pytest.raises(RecorderError, match=r"/x/y: field a\.b\[1\] \(set\)"),
    ):
        recorder.log("/x/y", 0.0, {"a": {"b": [1, {2, 3}]}})


@pytest.mark.parametrize("t_s", [-0.1, math.nan, math.inf])
def test_bad_sim_time_is_rejected(tmp_path: Path, t_s: float) -> None:
    with (
        McapRecorder(tmp_path / "run.mcap") as recorder,
        pytest.raises(RecorderError, match="sim time"),
    ):
        recorder.log(topics.GCS_CYCLE, t_s, cycle(0))


def test_close_is_idempotent_and_log_after_close_fails(tmp_path: Path) -> None:
    recorder = McapRecorder(tmp_path / "run.mcap")
    recorder.log(topics.GCS_CYCLE, 0.0, cycle(0))
    recorder.close()
    recorder.close()
    with pytest.raises(RecorderError, match="after close"):
        recorder.log(topics.GCS_CYCLE, 1.0, cycle(1))
    assert len(raw_messages(tmp_path / "run.mcap")) == 1


# --------------------------------------------------------------------------------------------
# Crashes: cut-off files


def test_a_file_cut_off_mid_write_is_readable_up_to_its_last_chunk(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    recorder = McapRecorder(path, chunk_size=4096, flush_every_s=None, foxglove=False)
    logged = []
    for k in range(3000):
        recorder.log(topics.GCS_CYCLE, 0.25 * k, cycle(k))
        logged.append((topics.GCS_CYCLE, 0.25 * k, {"t_s": 0.25 * k, **cycle(k)}))
    partial = tmp_path / "partial.mcap"
    shutil.copyfile(path, partial)  # what a crash right now would leave: no footer
    recorder.close()

    got = list(read_records(partial))
    assert 2000 < len(got) < 3000  # all but the open chunk
    assert got == logged[: len(got)]

    size = path.stat().st_size
    previous = 0
    for cut in (size // 7, size // 3 + 5, size // 2, size - 30, size - 1):
        cut_file = truncated_copy(path, tmp_path / f"cut{cut}.mcap", cut)
        got = list(read_records(cut_file))
        assert got == logged[: len(got)]
        assert len(got) >= previous
        previous = len(got)
    assert previous == 3000  # only the summary is cut off at size - 1


def test_flush_every_s_bounds_what_a_crash_loses(tmp_path: Path) -> None:
    copies = {}
    for flush_every_s in (1.0, None):
        path = tmp_path / f"run{flush_every_s}.mcap"
        recorder = McapRecorder(path, chunk_size=1 << 22, flush_every_s=flush_every_s)
        for k in range(46):
            recorder.log(topics.GCS_CYCLE, 0.1 * k, cycle(k))  # up to t = 4.5 s
        copies[flush_every_s] = shutil.copyfile(path, tmp_path / f"crash{flush_every_s}.mcap")
        recorder.close()
    flushed = [t for _topic, t, _r in read_records(copies[1.0])]
    assert flushed == pytest.approx([0.1 * k for k in range(41)])  # up to the flush at 4.0 s
    assert list(read_records(copies[None])) == []  # one big open chunk: everything lost


def test_a_file_that_is_not_mcap_is_a_clear_error(tmp_path: Path) -> None:
    bad = tmp_path / "bad.mcap"
    bad.write_text("hello")
    with pytest.raises(LogReadError, match="not an MCAP file"):
        list(read_records(bad))
    with pytest.raises(LogReadError, match="cannot open"):
        list(read_records(tmp_path / "missing.mcap"))


# --------------------------------------------------------------------------------------------
# Merging the parts of a live run


def test_merge_keeps_every_readable_message_in_time_order(tmp_path: Path) -> None:
    # Part A (complete): cycles at 0, 0.5, 1.0, ...; part B (cut off): decisions at 0.25, 0.75
    # ... and a cycle at 1.0 (a tie with A); part C: garbage.
    part_a = tmp_path / "gcs.mcap"
    with McapRecorder(part_a) as recorder:
        for k in range(400):
            recorder.log(topics.GCS_CYCLE, 0.5 * k, cycle(k))
    full_b = tmp_path / "companion_full.mcap"
    with McapRecorder(full_b, chunk_size=2048) as recorder:
        recorder.log(topics.GCS_CYCLE, 1.0, {**cycle(0), "from": "b"})
        for k in range(400):
            recorder.log(topics.DECISIONS, 0.25 + 0.5 * k, {"sysid": 1, "compute_ms": 1.0 * k})
    part_b = truncated_copy(full_b, tmp_path / "companion.mcap", full_b.stat().st_size // 2)
    part_c = tmp_path / "sim.mcap"
    part_c.write_bytes(b"\x89MCAP0\r\n" + b"\x00" * 5)

    readable_a = list(read_records(part_a))
    readable_b = list(read_records(part_b))
    assert 0 < len(readable_b) < 401
    out = tmp_path / "run.mcap"
    report = merge_parts([part_a, part_b, part_c], out)

    assert [(p.path, p.messages, p.complete) for p in report.parts] == [
        (part_a, 400, True),
        (part_b, len(readable_b), False),
        (part_c, 0, False),
    ]
    assert report.parts[2].error is not None
    assert not report.complete
    merged = list(read_records(out))
    assert report.messages == len(merged) == len(readable_a) + len(readable_b)
    assert sorted(map(repr, merged)) == sorted(map(repr, readable_a + readable_b))
    times = [t for _topic, t, _r in merged]
    assert times == sorted(times)
    at_one = [r for _topic, t, r in merged if t == 1.0 and _topic == topics.GCS_CYCLE]
    assert [r.get("from") for r in at_one] == [None, "b"]  # ties keep the parts' order
    with open(out, "rb") as stream:
        summary = make_reader(stream).get_summary()
    assert summary is not None
    channel_topics = [c.topic for c in summary.channels.values()]
    assert sorted(channel_topics) == sorted({topics.GCS_CYCLE, topics.DECISIONS})


def test_merge_refuses_to_overwrite_a_part(tmp_path: Path) -> None:
    part = tmp_path / "a.mcap"
    write_cycles(part, 3)
    with pytest.raises(ValueError, match="also one of the parts"):
        merge_parts([part], part)


# --------------------------------------------------------------------------------------------
# Foxglove


def meta_record() -> dict[str, Any]:
    return {
        "mode": "lockstep",
        "seed": 1,
        "planner": "spoofing_aware",
        "scenario": {"scenario": {"origin": ORIGIN}},
        "aircraft": [],
        "spoofer": None,
        "nmac_threshold_m": 50.0,
    }


def truth_record(t_s: float) -> dict[str, Any]:
    return {
        "sysid": [1, 2, 3],
        "p_enu_m": [[10.0 * t_s, 0.0, 60.0], [0.0, 100.0, 50.0], [-200.0 + 7 * t_s, 5.0, 60.0]],
        "v_enu_m_s": [[10.0, 0.0, 0.0], [0.0, 0.0, 0.0], [7.0, 0.0, 0.0]],
        "armed": [True, True, True],
        "mode": [4, 4, 4],
        "spoofer_sysid": 3,
        "spoofer_claimed_p_enu_m": [-150.0 + 7 * t_s, 55.0, 60.0],
    }


def rotated_cov() -> FloatArray:
    rotation = Rotation.from_euler("zyx", [35.0, -20.0, 50.0], degrees=True).as_matrix()
    return np.asarray(rotation @ np.diag([900.0, 100.0, 2500.0]) @ rotation.T)


def region_record(cov: FloatArray) -> dict[str, Any]:
    return {
        "uas_id": "RSAF800000666",
        "track_id": 7,
        "center_enu_m": [-190.0, 10.0, 55.0],
        "cov_enu_m2": cov.tolist(),
        "chi2_threshold": CHI2_95,
        "alpha": 0.05,
        "valid_until_s": 2.0,
        "semi_axes_m": [0.0, 0.0, 0.0],
    }


def by_topic(messages: list[dict[str, Any]]) -> dict[str, list[dict[str, Any]]]:
    grouped: dict[str, list[dict[str, Any]]] = {}
    for m in messages:
        grouped.setdefault(m["topic"], []).append(m)
    return grouped


def test_foxglove_channels_are_derived_with_the_right_schemas(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with McapRecorder(path) as recorder:
        recorder.log(topics.RUN_META, 0.0, meta_record())
        for k in range(26):  # 0.0 .. 2.5 s at 10 Hz
            recorder.log(topics.TRUTH, 0.1 * k, truth_record(0.1 * k))
            if k == 10:
                recorder.log(topics.REGIONS, 1.0, region_record(rotated_cov()))
    grouped = by_topic(raw_messages(path))
    schema_of = {topic: ms[0]["schema_name"] for topic, ms in grouped.items()}
    assert schema_of == {
        topics.RUN_META: topics.RUN_META,
        topics.TRUTH: topics.TRUTH,
        topics.REGIONS: topics.REGIONS,
        "/foxglove/tf": "foxglove.FrameTransform",
        "/foxglove/aircraft": "foxglove.SceneUpdate",
        "/foxglove/unsafe_regions": "foxglove.SceneUpdate",
        "/foxglove/location/1": "foxglove.LocationFix",
        "/foxglove/location/2": "foxglove.LocationFix",
        "/foxglove/location/3": "foxglove.LocationFix",
    }
    assert grouped["/foxglove/aircraft"][0]["schema"] == foxglove.SCHEMAS["foxglove.SceneUpdate"]

    (tf,) = grouped["/foxglove/tf"]
    assert tf["log_time"] == 0
    assert (tf["data"]["parent_frame_id"], tf["data"]["child_frame_id"]) == ("world", "enu")
    assert tf["data"]["rotation"] == {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}

    scenes = grouped["/foxglove/aircraft"]
    assert len(scenes) == 26
    entities = {e["id"]: e for e in scenes[5]["data"]["entities"]}  # t = 0.5 s
    assert sorted(entities) == ["spoofer/claimed", "vehicle/1", "vehicle/2", "vehicle/3"]
    assert all(e["frame_id"] == "enu" for e in entities.values())
    assert entities["vehicle/1"]["timestamp"] == {"sec": 0, "nsec": 500_000_000}
    position = entities["vehicle/3"]["spheres"][0]["pose"]["position"]
    assert (position["x"], position["y"], position["z"]) == pytest.approx((-196.5, 5.0, 60.0))
    colour = {k: e["spheres"][0]["color"] for k, e in entities.items()}
    assert colour["vehicle/3"] != colour["vehicle/1"] == colour["vehicle/2"]
    assert colour["spoofer/claimed"]["a"] < 1.0 == colour["vehicle/3"]["a"]

    fixes = grouped["/foxglove/location/3"]
    assert [f["log_time"] for f in fixes] == [0, 1_000_000_000, 2_000_000_000]  # 1 Hz
    origin = GeodeticOrigin(**ORIGIN)
    lat, lon, alt = enu_to_geodetic(origin, [-193.0, 5.0, 60.0])  # sysid 3 at t = 1 s
    fix = fixes[1]["data"]
    assert (fix["latitude"], fix["longitude"], fix["altitude"]) == pytest.approx(
        (float(lat), float(lon), float(alt)), abs=1e-9
    )

    (region_scene,) = grouped["/foxglove/unsafe_regions"]
    (entity,) = region_scene["data"]["entities"]
    assert entity["lifetime"] == {"sec": 1, "nsec": 0}  # valid until 2.0 s, sent at 1.0 s
    check_ellipsoid(entity["spheres"][0], rotated_cov(), CHI2_95, [-190.0, 10.0, 55.0])


def check_ellipsoid(sphere: dict[str, Any], cov: FloatArray, chi2: float, center: Any) -> None:
    """The sphere primitive is the ellipsoid x^T P^-1 x <= chi2 about ``center``."""
    size = np.array([sphere["size"][a] for a in "xyz"])
    q = sphere["pose"]["orientation"]
    rotation = Rotation.from_quat([q["x"], q["y"], q["z"], q["w"]]).as_matrix()
    assert [sphere["pose"]["position"][a] for a in "xyz"] == pytest.approx(center)
    # Half-sizes and axes against the eigen-decomposition computed here.
    eigenvalues, vectors = np.linalg.eigh(cov)
    semi_axes = np.sqrt(chi2 * eigenvalues)
    assert sorted(size / 2.0) == pytest.approx(sorted(semi_axes))
    for k in range(3):
        match = int(np.argmin(np.abs(semi_axes - size[k] / 2.0)))
        assert abs(float(rotation[:, k] @ vectors[:, match])) == pytest.approx(1.0)
    # The whole shape: A = R diag(size / 2) maps the unit ball onto the ellipsoid: A A^T = chi2 P.
    a = rotation @ np.diag(size / 2.0)
    assert a @ a.T == pytest.approx(chi2 * cov)


def test_ellipsoid_orientation_is_a_proper_rotation_for_many_covariances() -> None:
    rng = np.random.default_rng(7)
    improper_from_eigh = 0
    for _ in range(200):
        rotation = Rotation.random(random_state=rng).as_matrix()
        cov = rotation @ np.diag(rng.uniform(1.0, 3000.0, 3)) @ rotation.T
        improper_from_eigh += int(np.linalg.det(np.linalg.eigh(cov)[1]) < 0.0)
        scene = foxglove.regions_scene(3.0, region_record(cov))
        check_ellipsoid(scene["entities"][0]["spheres"][0], cov, CHI2_95, [-190.0, 10.0, 55.0])
    assert improper_from_eigh > 0  # the det = -1 branch was exercised


def test_quaternion_from_matrix_agrees_with_scipy() -> None:
    rng = np.random.default_rng(3)
    half_turns = [Rotation.from_rotvec(math.pi * np.array(axis)) for axis in np.eye(3)]
    cases = [*Rotation.random(300, random_state=rng), *half_turns, Rotation.identity()]
    for rotation in cases:
        q = np.array(foxglove.quaternion_from_matrix(rotation.as_matrix()))
        expected = rotation.as_quat()
        expected = expected if expected[3] >= 0.0 else -expected
        if abs(expected[3]) < 1e-12:  # w = 0: q and -q are both valid
            expected = expected * np.sign(expected @ q)
        assert q == pytest.approx(expected, abs=1e-12)


def test_location_fixes_need_an_origin(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    without, given = tmp_path / "without.mcap", tmp_path / "given.mcap"
    with caplog.at_level(logging.WARNING), McapRecorder(without) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    assert "no scenario origin" in caplog.text
    with McapRecorder(given, origin=GeodeticOrigin(**ORIGIN)) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    assert not any(t.startswith("/foxglove/location/") for t, _, _ in read_records(without))
    assert sum(t.startswith("/foxglove/location/") for t, _, _ in read_records(given)) == 3


def test_merge_keeps_one_copy_of_identical_derived_messages(tmp_path: Path) -> None:
    sim, gcs = tmp_path / "sim.mcap", tmp_path / "gcs.mcap"
    with McapRecorder(sim, origin=GeodeticOrigin(**ORIGIN)) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    with McapRecorder(gcs) as recorder:
        recorder.log(topics.REGIONS, 0.25, region_record(rotated_cov()))
    report = merge_parts([sim, gcs], tmp_path / "run.mcap")
    grouped = by_topic(raw_messages(tmp_path / "run.mcap"))
    assert len(grouped["/foxglove/tf"]) == 1  # both parts wrote the same transform
    assert report.duplicates_dropped == 1
    assert report.messages == report.parts[0].messages + report.parts[1].messages - 1


def test_aircraft_scene_text_equals_the_marker_entities() -> None:
    """Differential: the pre-encoded fast path against the plain dict builders."""
    truth = truth_record(1.5)
    truth["p_enu_m"][1] = [0.0, math.nan, 50.0]  # non-finite: left out
    truth["armed"] = [True, False, True]
    scene = json.loads(foxglove.aircraft_scene(1.5, truth))
    assert scene == {
        "deletions": [],
        "entities": [
            foxglove.marker_entity(
                1.5,
                "vehicle/1",
                [15.0, 0.0, 60.0],
                foxglove.BENIGN_COLOUR,
                "1",
                {"sysid": "1", "armed": "True"},
            ),
            foxglove.marker_entity(
                1.5,
                "vehicle/3",
                [-189.5, 5.0, 60.0],
                foxglove.SPOOFER_COLOUR,
                "3 spoofer",
                {"sysid": "3", "armed": "True"},
            ),
            foxglove.marker_entity(
                1.5,
                "spoofer/claimed",
                [-139.5, 55.0, 60.0],
                foxglove.CLAIMED_COLOUR,
                "3 claimed",
            ),
        ],
    }
