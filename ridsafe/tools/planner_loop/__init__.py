"""The planner-only closed loop: the smallest world that closes the loop around the planner
(no MAVLink, radio or GCS), so its safety can be measured alone (``bench/planner_closed_loop.py``,
``tests/tools/planner_loop``) and its unit tests can fly scripted encounters.

- ``layout``: configuration and the seeded layout; ``fleets``: the aircraft models;
  ``closed_loop``: ``run_closed_loop``; ``scripted``: ``fly`` and ``ScriptedSpoofer``.
"""
