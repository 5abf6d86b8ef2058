"""Channel calibration: the GCS learns the radio channel from its cooperative aircraft."""
