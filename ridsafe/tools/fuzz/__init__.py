"""Fuzzing the cores: mutations of captured MAVLink (``mutate``) fed to each core
(``harness``); ``bench/bench_fuzz.py`` runs a campaign, ``tests/tools/fuzz`` a short one."""
