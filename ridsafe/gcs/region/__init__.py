"""The chance-constrained unsafe region around an estimate (``unsafe_region.py``)."""
