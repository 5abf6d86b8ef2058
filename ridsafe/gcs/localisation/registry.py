"""The estimators a track can be run with, by the name ``pipeline.estimator`` gives in YAML.

Each entry maps a name to the function that starts that estimator's localiser, written as
``"module:function"`` (imported when a track first needs it, see ``api.estimator_start``):
loading a configuration checks the name against this table without importing any estimator.

How to add an estimator (one new module plus one line here):

1. Write ``ridsafe/gcs/localisation/<name>.py`` with

   - a class with the ``api.Localiser`` methods: ``update(claim) -> bool`` (use one observed
     claim, True when it changed the estimate) and ``predicted(t_s) -> (Gaussian, mu)`` (the
     fused estimate as a batch of one in CV order - position, velocity, then any extra
     states - and the mode probabilities, without advancing the stored state);
   - a start function with the ``api.StartLocaliser`` signature
     ``start(claims, cfg, after_s) -> (localiser, how many claims it used) | None``: given
     the alerted transmitter's recent claims (oldest first), start a localiser from the
     first ones that allow it (claims up to ``after_s`` were tried already), or None.

   Reuse what is there: ``multilateration`` (NLLS fixes), ``rssi_update`` (RSSI measurement
   model and its iterated update), ``tracking.imm`` and ``tracking.motion_models`` (the IMM
   and its CV / CA models), ``initiation.grid`` (a grid posterior to start from). Parameters
   of your own go in a new section of ``ridsafe/gcs/pipeline_config.py``.
2. Add ``"<name>": "ridsafe.gcs.localisation.<name>:start"`` to ``ESTIMATORS`` below.

Then ``pipeline.estimator: <name>`` in a scenario's YAML (or ``--set
pipeline.estimator=<name>``) runs it, and ``bench/bench_gcs.py --mc`` compares it with the
others once listed in its ``ESTIMATORS``. ``tests/gcs/localisation/test_registry.py`` checks
that every entry loads and starts a track.
"""

from __future__ import annotations

from ridsafe.common.errors import FieldValueError

__all__ = ["DEFAULT_ESTIMATOR", "ESTIMATORS", "check_estimator"]

#: name (the value of ``pipeline.estimator``) -> ``"module:function"`` that starts its localiser
ESTIMATORS: dict[str, str] = {
    # ours: a Gaussian sum of IMMs updated on the raw RSSI, transmit power as a state
    "rssi_imm": "ridsafe.gcs.localisation.gaussian_sum:start",
    # the paper's: an NLLS fix per claim -> linear IMM update
    "nlls_imm": "ridsafe.gcs.localisation.nlls_imm:start",
    # the paper's as the authors' code ran it: EMA-tracked power, inflated fix covariance,
    # no mode mixing, soft gating (docs/paper_mode.md)
    "authors_imm": "ridsafe.gcs.localisation.authors_imm:start",
}

DEFAULT_ESTIMATOR = "rssi_imm"


def check_estimator(name: str) -> None:
    """Raise ``FieldValueError('estimator', ...)`` unless ``name`` is registered (the config
    loader reports it at its key path, ``pipeline.estimator``)."""
    if name not in ESTIMATORS:
        known = ", ".join(sorted(ESTIMATORS))
        raise FieldValueError(
            "estimator",
            f"unknown estimator {name!r}; registered: {known} "
            "(add one in ridsafe/gcs/localisation/registry.py)",
        )
