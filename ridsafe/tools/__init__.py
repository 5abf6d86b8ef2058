"""Tools around the apps: the ``ridsafe`` command, the runners, the run log and its analysis.

Rooms, by job (each package's docstring lists its modules):

- ``cli``: argument parsing and one ``*_cmd`` module per ``ridsafe`` subcommand; nothing else.
- ``run``: the scenario file, the one factory of the cores (``run.cores``), the lockstep and
  live runners and what an app process needs around its core.
- ``runlog``: the run log (MCAP): writer (with the Foxglove views as a plug-in), child-process
  writer, reader, part merge. The record schema is ``ridsafe.common.topics`` (apps write it).
- ``analysis``: everything computed from logs: encounters (NMAC counting), metrics, time
  series, sweep results, report, plots.
- ``sweep``: the experiment matrix flown as lockstep runs, resumably, on a pool or Dask.
- ``planner_loop``: the planner-only closed loop (benchmarks and planner tests).

Apps never import ``tools``; ``tools`` imports the apps to build and run them.
"""
