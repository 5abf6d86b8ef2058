"""Sweeps: the experiment matrix flown as deterministic lockstep runs, resumably.

- ``config``: the ``sweep:`` section (``SweepConfig``), a leaf the scenario file can hold.
- ``plan``: the matrix as run specs, the scenario each flies and its digest.
- ``folder``: the sweep folder's files, run outcomes, what counts as finished.
- ``runner``: ``run_sweep`` and the ``Engine`` protocol; ``engines``: process pool and Dask.
"""
