"""Fill the on-disk caches a test session reads, in a process of its own beside the session.

A clean clone has neither numba's compiled kernels (``ridsafe/**/__pycache__/*.nb[ci]``) nor
mypy's cache (``.mypy_cache``): the session's first lockstep run compiles the kernels, and
``tests/test_quality.py`` type-checks every module from scratch, both on one core while the
other is mostly idle. ``tests/conftest.py`` starts this module at the lowest priority when a
cache is missing, so that the idle core fills it: a test that needs a kernel then loads it
from the cache (or, if it comes first, compiles it as it would have anyway), and mypy reads
its cache. Neither cache changes what a test checks: numba caches the code it would compile,
and mypy's cache is keyed on the sources and the options.

The GCS's kernels come first and the planner's next: the session's first lockstep run
compiles the sim's first, so the two processes meet in the middle instead of compiling the
same kernel side by side.

``python -m tests.warm_caches [numba] [mypy]``: which caches to fill (both by default).
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from ridsafe.common.pathloss import received_power_dbm
from ridsafe.companion.planner import AwarePlanner
from ridsafe.companion.planner_config import PlannerConfig
from ridsafe.gcs.detection.censored import CensoredLikelihoodDetector
from ridsafe.gcs.pipeline import EstimationPipeline
from ridsafe.gcs.pipeline_api import ObservedClaim
from ridsafe.gcs.pipeline_config import DetectionConfig, PipelineConfig
from ridsafe.tools.run.lockstep import warm_up as warm_up_run
from ridsafe.tools.run.scenario import load_scenario_file

ROOT = Path(__file__).resolve().parents[1]


def _warm_censored_detector() -> None:
    """MLAT_CENSORED (off by default, so no run's warm-up loads it): one window of claims
    heard near the cut."""
    rx = np.array([[0.0, 0.0, 50.0], [300.0, 0.0, 80.0], [0.0, 300.0, 40.0], [300.0, 300, 60]])
    p = np.array([150.0, 150.0, 60.0])
    rssi = received_power_dbm(20.0, np.linalg.norm(rx - p, axis=1))
    config = PipelineConfig(detection=DetectionConfig(censored_window_s=10.0))
    detector = CensoredLikelihoodDetector("warm-up", config)
    for t_s in (0.0, 1.0):
        detector.observe(
            ObservedClaim(
                uas_id="warm-up",
                rid_timestamp_s=t_s,
                claimed_p_enu_m=p + 50.0,
                claimed_v_enu_m_s=None,
                rx_sysid=np.arange(1, 5, dtype=np.int64),
                rx_p_enu_m=rx,
                rx_t_s=np.full(4, t_s),
                rssi_dbm=rssi,
                cut_rssi_dbm=rssi,
                cut_floor_dbm=np.full(4, float(rssi.min()) - 1.0),
            )
        )


def warm_numba() -> None:
    """Load or compile every kernel a run of the default scenario and of the robustness
    sweep's calls, and the off-by-default detector's."""
    EstimationPipeline.ensure_warm()  # once per process: the builds below skip it
    AwarePlanner(PlannerConfig(), "warm-up").warm_up()
    _warm_censored_detector()
    for config in (None, ROOT / "configs" / "robustness.yaml"):
        warm_up_run(load_scenario_file(config), "aware")


def warm_mypy() -> None:
    """mypy as ``tests/test_quality.py`` runs it (the same options, so the same cache)."""
    subprocess.run([sys.executable, "-m", "mypy"], cwd=ROOT, capture_output=True, check=False)


def main(argv: list[str]) -> None:
    which = set(argv) or {"numba", "mypy"}
    if unknown := which - {"numba", "mypy"}:
        raise SystemExit(f"warm_caches: unknown cache(s) {sorted(unknown)}; numba or mypy")
    os.nice(19)  # the session's tests first: this takes only the CPU they leave
    if "numba" in which:
        warm_numba()
    if "mypy" in which:
        warm_mypy()


if __name__ == "__main__":
    main(sys.argv[1:])
