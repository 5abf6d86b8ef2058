"""ridsafe: spoofing-aware Remote ID trajectory planning for small drones.

Packages (no app imports another app; ``common`` imports no app):

- ``ridsafe.common``: what both ends of a link agree on (messages, MAVLink codec and
  dialect, ASTM F3411, frames, path loss, config, clock, UDP endpoint).
- ``ridsafe.sim_backend``: 6-DoF octorotors behind ArduCopter-like MAVLink autopilots,
  RID transponders and the radio channel.
- ``ridsafe.companion``: the per-aircraft companion computer app.
- ``ridsafe.gcs``: the ground control station app.
- ``ridsafe.tools``: the ``ridsafe`` command line, the runners (one factory builds the cores
  for lockstep and live), the run log and its analysis, sweeps.
"""

__version__ = "0.1.0"
