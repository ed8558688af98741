"""Training: run configuration and hyperparameters (rl-zoo3 YAML), one run, sweeps on Ray Tune,
task schedules, kick-starting and the SB3 adapter of the native vector env."""
