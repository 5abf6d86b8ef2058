"""Seeded synthetic traffic for the estimation pipeline (``traffic.py``) and the measurements
the GCS tests and ``bench/bench_gcs.py`` take over it (``evaluate.py``)."""
