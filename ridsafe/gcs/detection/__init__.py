"""Spoofing detection: does an observed claim agree with the radio's physics?

``registry.py`` (which detectors run, and how to add one), ``monitor.py`` (every detector of
one claimed transmitter), ``rssi_consistency.py`` (the five RSSI tests, the paper's NIS among
them) with its compiled kernel ``rssi_consistency_kernels.py``.
"""
