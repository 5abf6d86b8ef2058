"""Running a scenario: the scenario file, the one factory of the cores, and the runners.

- ``scenario``: the scenario file (``ScenarioFile``, ``RunConfig``); ``scenario_family``: the
  paper's scenario family drawn per seed.
- ``cores``: the one factory of the sim backend, companions and GCS (every runner uses it).
- ``lockstep``: all cores in one process on one clock; ``live``: one process per app over UDP.
- ``process``: what an app process needs around its core (clock, start, log, signing, SIGTERM).
- ``run_records``: the ``/run/meta`` and ``/run/end`` records; ``demo``: the demo's ground station.
"""
