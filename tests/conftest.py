"""Test session settings: single-threaded BLAS, as every ridsafe process runs (see cli.py),
and no time limit on a hypothesis example: speed is measured in ``bench/``, and a first
example that loads a compiled kernel from numba's cache (0.1-0.4 s) or a loaded CI host
would otherwise fail a property test for its clock, not its property."""

import os

from hypothesis import settings

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

settings.register_profile("ridsafe", deadline=None)
settings.load_profile("ridsafe")
