"""The tracking filter: motion models (``motion_models.py``: CV, CA) and the IMM that mixes
them (``imm.py``, compiled kernels ``imm_kernels.py``)."""
