"""Two episodes of the benchmark's reach suites (seed 0) that the baseline tests play: one the
slider line solves, one where neither the slider line nor the straight pose path is safe."""

from __future__ import annotations

from planar3p_agents.evaluation.reach_suites import EpisodeSpec

#: Their working mode.
MODE = (1, 1, -1)
#: Episode 0 of the ``standard`` suite of seed 0: the slider line solves it.
STANDARD = EpisodeSpec(
    "standard",
    0,
    (-0.014130103980426634, 0.08874557796781271, 0.21442711562825648),
    (0.061531177825434324, 0.18644608444136282, -0.23570030702573236),
    MODE,
)
#: Episode 0 of the ``hard`` suite of seed 0: neither the slider line nor the straight pose
#: path is safe (it passes within 0.01 of a parallel singularity).
HARD = EpisodeSpec(
    "hard",
    0,
    (-0.006128449623607257, 0.029483208287819057, 0.28866444721929224),
    (0.019764311544887725, 0.01222494475140368, -0.5759581934985943),
    MODE,
)
