"""Where a track starts: the grid posterior over a transmitter's position from its first
claims (``grid.py``, compiled costs in ``grid_kernels.py``)."""
