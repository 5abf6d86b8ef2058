"""The paper's published values (Tables 2 and 3), beside which a report puts ours.

:data:`PUBLISHED`: (metric, planner) -> density -> (mean, std), each over
:data:`PUBLISHED_RUNS` runs. Metric keys are those of ``analysis.metrics`` plus ``total_nmac``
(benign-benign + benign-spoofer, the paper's "Total NMACs").
"""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["PUBLISHED", "PUBLISHED_RUNS", "Published"]

Published = Mapping[int, tuple[float, float]]  # density -> (mean, std)

_SA, _RID = "aware", "trust-rid"  # the paper's "SA" and "RID" / "Trust-RID"
#: (metric, planner, (mean, std) at 4, 8, 12 and 16 aircraft), as published.
_PAPER_ROWS: tuple[
    tuple[
        str, str, tuple[float, float], tuple[float, float], tuple[float, float], tuple[float, float]
    ],
    ...,
] = (
    # Table 2 (tab:merged_clean), block "Safety Metrics (SA)", rows "Total NMACs",
    # "Benign--Benign", "Benign--Spoofer", "Unsafe violations"
    ("total_nmac", _SA, (0.300, 0.466), (1.733, 1.230), (4.067, 2.545), (7.000, 3.311)),
    ("nmac_benign_benign", _SA, (0.267, 0.450), (1.633, 1.273), (3.700, 2.409), (6.767, 3.245)),
    ("nmac_benign_spoofer", _SA, (0.033, 0.183), (0.100, 0.305), (0.367, 0.556), (0.233, 0.568)),
    ("unsafe_violations", _SA, (2.700, 3.669), (0.933, 1.230), (1.533, 2.177), (3.033, 2.965)),
    # Table 2, block "Safety Metrics (RID)", rows "Total NMACs", "Benign--Benign",
    # "Benign--Spoofer" (its "Unsafe violations" row is "--")
    ("total_nmac", _RID, (0.267, 0.450), (1.933, 1.507), (4.933, 1.929), (8.967, 3.264)),
    ("nmac_benign_benign", _RID, (0.267, 0.450), (1.200, 1.064), (3.533, 1.655), (6.767, 2.967)),
    ("nmac_benign_spoofer", _RID, (0.000, 0.000), (0.733, 0.691), (1.400, 0.814), (2.200, 0.805)),
    # Table 2, block "Localization Metrics (SA only)", rows "Containment rate", "RMSE (m)",
    # "MAE (m)", "Ellipsoid radius (m)"
    ("containment_rate", _SA, (0.478, 0.259), (0.804, 0.186), (0.894, 0.109), (0.839, 0.106)),
    ("rmse_m", _SA, (334.394, 434.679), (71.953, 32.075), (57.274, 22.065), (63.649, 15.694)),
    ("mae_m", _SA, (239.724, 308.027), (61.286, 26.111), (48.596, 16.370), (51.190, 11.357)),
    (
        "max_ellipsoid_radius_m",
        _SA,
        (81.687, 6.848),
        (87.534, 2.338),
        (87.334, 2.075),
        (87.885, 1.184),
    ),
    # Table 3 (tab:runtime_by_scenario_sa_rid), columns "Total wall-clock" SA and Trust-RID,
    # rows 4, 8, 12, 16
    ("wall_clock_s", _SA, (40.07, 3.70), (83.60, 21.94), (188.40, 48.08), (221.77, 39.36)),
    ("wall_clock_s", _RID, (31.53, 4.61), (82.57, 14.72), (153.70, 27.35), (108.23, 13.56)),
    # Table 3, columns "GCS compute" SA and Trust-RID, rows 4, 8, 12, 16
    ("gcs_compute_s", _SA, (5.42, 0.68), (4.66, 0.33), (6.27, 0.92), (7.24, 1.11)),
    ("gcs_compute_s", _RID, (0.14, 0.02), (0.36, 0.06), (0.58, 0.12), (0.39, 0.04)),
)
#: The paper's published values: (metric, planner) -> density -> (mean, std), 30 runs each.
PUBLISHED: Mapping[tuple[str, str], Published] = {
    (key, planner): dict(zip((4, 8, 12, 16), values, strict=True))
    for key, planner, *values in _PAPER_ROWS
}
PUBLISHED_RUNS = 30
