"""The Foxglove views of a run log: a plug-in of the writer that derives typed channels.

So that ``OUT/run.mcap`` opens usefully in Foxglove (3D and Map panels), the recorder runs
:class:`FoxgloveChannels` (``McapRecorder(path, plugins=[FoxgloveChannels(origin)])``),
which derives from the run's own records:

=============================  =========================  ==============================
topic                          schema                     from
=============================  =========================  ==============================
``/foxglove/tf``               ``foxglove.FrameTransform`` once, t = 0: "world" -> "enu"
``/foxglove/aircraft``         ``foxglove.SceneUpdate``    every ``/truth/vehicles``
``/foxglove/unsafe_regions``   ``foxglove.SceneUpdate``    every ``/gcs/unsafe_regions``
``/foxglove/location/<sysid>`` ``foxglove.LocationFix``    ``/truth/vehicles`` at 1 Hz
=============================  =========================  ==============================

The geodetic conversion needs the scenario origin: the plug-in takes it from the
``/run/meta`` record (``scenario.scenario.origin``) or from its ``origin`` argument (for a
process of a live run that does not log ``/run/meta``). The messages are built in
``foxglove_scenes``; the schemas are in ``foxglove_schemas``.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Mapping
from typing import Any

from ridsafe.common import topics
from ridsafe.common.frames import GeodeticOrigin
from ridsafe.common.logsink import Record
from ridsafe.tools.runlog import foxglove_scenes as scenes
from ridsafe.tools.runlog.foxglove_schemas import (
    FRAME_TRANSFORM,
    LOCATION_FIX,
    SCENE_UPDATE,
    SCHEMAS,
)
from ridsafe.tools.runlog.writer import DerivedChannels

__all__ = [
    "AIRCRAFT_TOPIC",
    "LOCATION_FIX_PERIOD_S",
    "REGIONS_TOPIC",
    "TF_TOPIC",
    "TOPIC_PREFIX",
    "FoxgloveChannels",
    "location_topic",
    "origin_from_meta",
]

logger = logging.getLogger(__name__)

TOPIC_PREFIX = "/foxglove/"
AIRCRAFT_TOPIC = "/foxglove/aircraft"
REGIONS_TOPIC = "/foxglove/unsafe_regions"
TF_TOPIC = "/foxglove/tf"
LOCATION_TOPIC_PREFIX = "/foxglove/location/"
LOCATION_FIX_PERIOD_S = 1.0


def location_topic(sysid: int) -> str:
    return f"{LOCATION_TOPIC_PREFIX}{sysid}"


def origin_from_meta(meta: Mapping[str, Any]) -> GeodeticOrigin | None:
    """The scenario origin of a ``/run/meta`` record (``scenario.scenario.origin``, or
    ``scenario.origin``), or None when it has none."""
    scenario = meta.get("scenario")
    if not isinstance(scenario, Mapping):
        return None
    inner = scenario.get("scenario")
    origin = (inner if isinstance(inner, Mapping) else scenario).get("origin")
    if not isinstance(origin, Mapping):
        return None
    return GeodeticOrigin(
        float(origin["lat_deg"]), float(origin["lon_deg"]), float(origin.get("alt_m", 0.0))
    )


class FoxgloveChannels:
    """Writer plug-in deriving the Foxglove channels of the module docstring.

    ``origin``: the scenario origin for the ``LocationFix`` channels when the records carry
    no ``/run/meta`` (else the first ``/run/meta``'s origin is taken)."""

    topics = (topics.RUN_META, topics.TRUTH, topics.REGIONS)

    def __init__(self, origin: GeodeticOrigin | None = None) -> None:
        self.origin = origin
        self._tf_written = False
        self._next_fix_s = 0.0
        self._warned_no_origin = False

    def on_record(self, topic: str, t_s: float, record: Record, out: DerivedChannels) -> None:
        if topic == topics.TRUTH:
            self._on_truth(t_s, record, out)
        elif topic == topics.REGIONS:
            self._ensure_tf(out)
            scene = scenes.regions_scene(t_s, record)
            out.write_derived(REGIONS_TOPIC, SCENE_UPDATE, SCHEMAS[SCENE_UPDATE], t_s, scene)
        elif topic == topics.RUN_META and self.origin is None:
            self.origin = origin_from_meta(record)

    def _ensure_tf(self, out: DerivedChannels) -> None:
        if not self._tf_written:
            self._tf_written = True
            tf = scenes.world_to_enu_transform(0.0)
            out.write_derived(TF_TOPIC, FRAME_TRANSFORM, SCHEMAS[FRAME_TRANSFORM], 0.0, tf)

    def _on_truth(self, t_s: float, record: Record, out: DerivedChannels) -> None:
        self._ensure_tf(out)
        scene = scenes.aircraft_scene(t_s, record)
        out.write_derived(AIRCRAFT_TOPIC, SCENE_UPDATE, SCHEMAS[SCENE_UPDATE], t_s, scene)
        if t_s < self._next_fix_s:
            return
        self._next_fix_s = (math.floor(t_s / LOCATION_FIX_PERIOD_S) + 1) * LOCATION_FIX_PERIOD_S
        if self.origin is None:
            if not self._warned_no_origin:
                self._warned_no_origin = True
                logger.warning("no scenario origin yet (/run/meta): LocationFix channels skipped")
            return
        for sysid, fix in scenes.location_fixes(t_s, record, self.origin):
            schema = SCHEMAS[LOCATION_FIX]
            out.write_derived(location_topic(sysid), LOCATION_FIX, schema, t_s, fix)
