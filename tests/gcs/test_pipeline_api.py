"""The claims' stacking helpers a GCS cycle calls for every claim it closes."""

from __future__ import annotations

import numpy as np

from ridsafe.gcs.pipeline_api import claimed_positions, reception_bounds
from tests.gcs.claims import observed_claim


def test_claims_stack_as_numpy_stacks_them() -> None:
    rng = np.random.default_rng(3)
    claims = [
        observed_claim(f"S{j}", 0.25 * j, rng.normal(0, 300, 3), rx, rng.normal(-70, 5, k))
        for j, (k, rx) in enumerate((k, rng.normal(0, 300, (k, 3))) for k in [3, 0, 1, 17, 5])
    ]
    stacked = claimed_positions(claims)
    assert stacked.dtype == np.float64 and stacked.flags.c_contiguous
    np.testing.assert_array_equal(stacked, np.stack([c.claimed_p_enu_m for c in claims]))
    np.testing.assert_array_equal(reception_bounds(claims), [0, 3, 3, 4, 21, 26])
    assert claimed_positions([]).shape == (0, 3)
    np.testing.assert_array_equal(reception_bounds([]), [0])
