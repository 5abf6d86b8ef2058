"""Estimators: from a transmitter's observed claims to a state estimate.

``registry.py`` (the estimators ``pipeline.estimator`` names, and how to add one),
``api.py`` (what a track needs from an estimator), ``gaussian_sum.py`` (ours, the default:
a Gaussian sum of RSSI IMMs; kernels ``mixture_kernels.py``), ``rssi_update.py`` (its RSSI
measurement update; kernels ``iplf_kernels.py``), ``nlls_imm.py`` (the paper's NLLS fix ->
IMM), ``multilateration.py`` (NLLS fixes).
"""
