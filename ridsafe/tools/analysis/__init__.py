"""Analysis of runs and sweeps: everything computed from run logs and sweep folders.

- ``run_arrays``: one run log as read-only arrays (truth, regions, tracks, alerts).
- ``encounters``: NMAC and region-entry counting (entry events), shared with the planner loop.
- ``metrics``: a run's metrics (definitions in its docstring); ``series``: the same over time.
- ``published``: the paper's values; ``sweep_results``: completed runs of sweep folders and
  the report's cells; ``report``: Markdown and CSV; ``plots``: PNG figures.
"""
