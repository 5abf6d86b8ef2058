"""Tests of the Foxglove views: the writer plug-in's derived channels in real MCAP files (read
back with the ``mcap`` library), their schemas, and the message builders (ellipsoids against an
independent eigen-decomposition, quaternions against scipy)."""

from __future__ import annotations

import json
import logging
import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from ridsafe.common import topics
from ridsafe.common.frames import GeodeticOrigin, enu_to_geodetic
from ridsafe.tools.runlog import foxglove_scenes
from ridsafe.tools.runlog.foxglove_channels import FoxgloveChannels, origin_from_meta
from ridsafe.tools.runlog.foxglove_schemas import SCHEMAS
from ridsafe.tools.runlog.reader import read_records
from ridsafe.tools.runlog.writer import McapRecorder
from tests.tools.runlog.mcap_files import (
    CHI2_95,
    ORIGIN,
    FloatArray,
    by_topic,
    check_schema,
    meta_record,
    raw_messages,
    region_record,
    rotated_cov,
    truth_record,
)


def log_a_scene(path: Path, plugins: Sequence[FoxgloveChannels]) -> None:
    """Meta, 2.5 s of truth at 10 Hz and one region at 1 s."""
    with McapRecorder(path, plugins=plugins) as recorder:
        recorder.log(topics.RUN_META, 0.0, meta_record())
        for k in range(26):  # 0.0 .. 2.5 s at 10 Hz
            recorder.log(topics.TRUTH, 0.1 * k, truth_record(0.1 * k))
            if k == 10:
                recorder.log(topics.REGIONS, 1.0, region_record(rotated_cov()))


def test_foxglove_channels_are_derived_with_the_right_schemas(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    log_a_scene(path, [FoxgloveChannels()])
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
    assert grouped["/foxglove/aircraft"][0]["schema"] == SCHEMAS["foxglove.SceneUpdate"]

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
        scene = foxglove_scenes.regions_scene(3.0, region_record(cov))
        check_ellipsoid(scene["entities"][0]["spheres"][0], cov, CHI2_95, [-190.0, 10.0, 55.0])
    assert improper_from_eigh > 0  # the det = -1 branch was exercised


def test_quaternion_from_matrix_agrees_with_scipy() -> None:
    rng = np.random.default_rng(3)
    half_turns = [Rotation.from_rotvec(math.pi * np.array(axis)) for axis in np.eye(3)]
    cases = [*Rotation.random(300, random_state=rng), *half_turns, Rotation.identity()]
    for rotation in cases:
        q = np.array(foxglove_scenes.quaternion_from_matrix(rotation.as_matrix()))
        expected = rotation.as_quat()
        expected = expected if expected[3] >= 0.0 else -expected
        if abs(expected[3]) < 1e-12:  # w = 0: q and -q are both valid
            expected = expected * np.sign(expected @ q)
        assert q == pytest.approx(expected, abs=1e-12)


def test_location_fixes_need_an_origin(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    without, given = tmp_path / "without.mcap", tmp_path / "given.mcap"
    plugins = [FoxgloveChannels()]
    with caplog.at_level(logging.WARNING), McapRecorder(without, plugins=plugins) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    assert "no scenario origin" in caplog.text
    with McapRecorder(given, plugins=[FoxgloveChannels(GeodeticOrigin(**ORIGIN))]) as recorder:
        recorder.log(topics.TRUTH, 0.0, truth_record(0.0))
    assert not any(t.startswith("/foxglove/location/") for t, _, _ in read_records(without))
    assert sum(t.startswith("/foxglove/location/") for t, _, _ in read_records(given)) == 3


def test_aircraft_scene_text_equals_the_marker_entities() -> None:
    """Differential: the pre-encoded fast path against the plain dict builders."""
    truth = truth_record(1.5)
    truth["p_enu_m"][1] = [0.0, math.nan, 50.0]  # non-finite: left out
    truth["armed"] = [True, False, True]
    scene = json.loads(foxglove_scenes.aircraft_scene(1.5, truth))
    assert scene == {
        "deletions": [],
        "entities": [
            foxglove_scenes.marker_entity(
                1.5,
                "vehicle/1",
                [15.0, 0.0, 60.0],
                foxglove_scenes.BENIGN_COLOUR,
                "1",
                {"sysid": "1", "armed": "True"},
            ),
            foxglove_scenes.marker_entity(
                1.5,
                "vehicle/3",
                [-189.5, 5.0, 60.0],
                foxglove_scenes.SPOOFER_COLOUR,
                "3 spoofer",
                {"sysid": "3", "armed": "True"},
            ),
            foxglove_scenes.marker_entity(
                1.5,
                "spoofer/claimed",
                [-139.5, 55.0, 60.0],
                foxglove_scenes.CLAIMED_COLOUR,
                "3 claimed",
            ),
        ],
    }


# --------------------------------------------------------------------------------------------
# The plug-in in the writer


def test_without_the_plugin_the_log_has_only_the_records(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    log_a_scene(path, [])
    logged = {m["topic"] for m in raw_messages(path)}
    assert logged == {topics.RUN_META, topics.TRUTH, topics.REGIONS}


def test_every_derived_message_satisfies_the_schema_of_its_channel(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    log_a_scene(path, [FoxgloveChannels()])
    derived = [m for m in raw_messages(path) if m["topic"].startswith("/foxglove/")]
    assert {m["schema_name"] for m in derived} == set(SCHEMAS)
    for message in derived:
        assert message["schema"] == SCHEMAS[message["schema_name"]]
        check_schema(message["data"], message["schema"], message["topic"])


def test_the_origin_comes_from_run_meta_unless_given(tmp_path: Path) -> None:
    given = GeodeticOrigin(0.5, 1.5, 10.0)
    from_meta, overridden = tmp_path / "meta.mcap", tmp_path / "given.mcap"
    log_a_scene(from_meta, [FoxgloveChannels()])
    log_a_scene(overridden, [FoxgloveChannels(given)])

    def first_fix(path: Path) -> tuple[float, float]:
        fix = next(r for t, _, r in read_records(path) if t == "/foxglove/location/2")
        return fix["latitude"], fix["longitude"]

    lat, lon, _alt = enu_to_geodetic(GeodeticOrigin(**ORIGIN), [0.0, 100.0, 50.0])
    assert first_fix(from_meta) == pytest.approx((float(lat), float(lon)), abs=1e-9)
    lat, lon, _alt = enu_to_geodetic(given, [0.0, 100.0, 50.0])
    assert first_fix(overridden) == pytest.approx((float(lat), float(lon)), abs=1e-9)


@pytest.mark.parametrize(
    ("meta", "expected"),
    [
        ({"scenario": {"scenario": {"origin": ORIGIN}}}, GeodeticOrigin(**ORIGIN)),
        ({"scenario": {"origin": {"lat_deg": 1.0, "lon_deg": 2.0}}}, GeodeticOrigin(1.0, 2.0)),
        ({"scenario": {"scenario": {}}}, None),
        ({"seed": 3}, None),
    ],
)
def test_origin_from_meta_reads_both_shapes(
    meta: dict[str, Any], expected: GeodeticOrigin | None
) -> None:
    assert origin_from_meta(meta) == expected


def test_a_record_the_plugin_cannot_view_is_still_written_and_warned_once(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    path = tmp_path / "run.mcap"
    broken = {"p_enu_m": [[0.0, 0.0, 60.0]]}  # no sysid
    with caplog.at_level(logging.WARNING), McapRecorder(path, plugins=[FoxgloveChannels()]) as rec:
        rec.log(topics.TRUTH, 0.0, broken)
        rec.log(topics.TRUTH, 0.1, broken)
        rec.log(topics.TRUTH, 0.2, truth_record(0.2))
    assert caplog.text.count("no derived view") == 1
    grouped = by_topic(raw_messages(path))
    assert len(grouped[topics.TRUTH]) == 3
    assert len(grouped["/foxglove/aircraft"]) == 1  # only the good record has a scene


def test_fixes_are_one_per_second_and_skip_unknown_positions(tmp_path: Path) -> None:
    path = tmp_path / "run.mcap"
    with McapRecorder(path, plugins=[FoxgloveChannels(GeodeticOrigin(**ORIGIN))]) as recorder:
        for k in range(25):  # 0.0 .. 2.4 s, vehicle 2 lost from 1.5 s on
            record = truth_record(0.1 * k)
            if k >= 15:
                record["p_enu_m"][1] = [None, None, None]
            recorder.log(topics.TRUTH, 0.1 * k, record)
    fixes = [(t, topic) for topic, t, _ in read_records(path) if topic.startswith("/foxglove/loc")]
    assert sorted({t for t, _ in fixes}) == pytest.approx([0.0, 1.0, 2.0])
    assert [topic for t, topic in fixes if t == pytest.approx(2.0)] == [
        "/foxglove/location/1",
        "/foxglove/location/3",
    ]


@pytest.mark.parametrize(
    ("valid_until_s", "lifetime"),
    [(None, {"sec": 0, "nsec": 0}), (0.5, {"sec": 0, "nsec": 100_000_000})],
)
def test_region_lifetime(valid_until_s: float | None, lifetime: dict[str, int]) -> None:
    """No validity: shown until replaced (0); already expired: shown briefly all the same."""
    record = {**region_record(rotated_cov()), "valid_until_s": valid_until_s}
    (entity,) = foxglove_scenes.regions_scene(1.0, record)["entities"]
    assert entity["lifetime"] == lifetime


@pytest.mark.parametrize(("flags", "label"), [(0, "unsafe"), (8, "stranger"), (10, "stranger")])
def test_a_strangers_region_is_drawn_apart(flags: int, label: str) -> None:
    record = {**region_record(rotated_cov()), "flags": flags}
    (entity,) = foxglove_scenes.regions_scene(1.0, record)["entities"]
    (text,) = entity["texts"]
    assert text["text"].split()[0] == label
    colour = foxglove_scenes.UNCONFIRMED_REGION_COLOUR if flags else foxglove_scenes.REGION_COLOUR
    (sphere,) = entity["spheres"]
    assert tuple(sphere["color"].values()) == colour
