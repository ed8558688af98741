""":meth:`Planar3PSim.reset` moves the bodies of the kept pymunk space (and
gives it a new machine's numbers) and is then, bit for bit, the simulation a new build at that
pose gives, whatever came before."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planar3p_gym.machine import kinematics
from planar3p_gym.machine.design import Design
from planar3p_gym.sim import physics
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.sim.randomization import REALISTIC_RANDOMIZATION, DynamicsRandomization
from planar3p_gym.tasks import sampling

DESIGN = Design.fig8()
MODE = (1, 1, -1)
#: Settings of the models a reset must move exactly: the projected physics (the ids), the
#: unprojected model, and a machine with every imperfection that adds constraints or forces.
MODELS = {
    "projected": {
        "projection": True,
        "substeps": physics.PROJECTED_SUBSTEPS,
        "iterations": physics.PROJECTED_ITERATIONS,
    },
    "unprojected": {},
    "imperfect": {
        "projection": True,
        "substeps": physics.PROJECTED_SUBSTEPS,
        "iterations": physics.PROJECTED_ITERATIONS,
        "dynamics": {
            "slider_coulomb": 0.5,
            "joint_coulomb": 0.01,
            "slider_viscous": 0.1,
            "servo_lag": 0.03,
            "joint_viscous": 1e-4,
            "gravity_tilt": 0.01,
            "inertia_scale": 1.1,
        },
    },
}


def starts(n: int) -> np.ndarray:
    poses, _ = sampling.sample_poses(DESIGN, MODE, np.random.default_rng(3), sampling.TaskConfig())
    return poses[:n]


def trace(sim: Planar3PSim, commands: np.ndarray) -> list:
    """Every state and every body's numbers along ``commands``."""
    out = [sim.state, sim.body_values()]
    for c in commands:
        out += [sim.step(c), sim.body_values()]
    return out


@pytest.mark.parametrize("name", sorted(MODELS))
def test_a_reset_simulation_is_the_new_build_bit_for_bit(name):
    kwargs = MODELS[name]
    poses = starts(6)
    rng = np.random.default_rng(0)
    sim = Planar3PSim(DESIGN, poses[0], MODE, **kwargs)
    for pose in poses[1:]:
        # A history to forget: commands up to the speed limit, into the end stops.
        for c in rng.uniform(-1.0, 1.0, (25, 3)) * DESIGN.max_speed:
            sim.step(c)
        commands = rng.uniform(-0.5, 0.5, (20, 3)) * DESIGN.max_speed
        assert sim.reset(pose, MODE) == sim.state
        assert sim.moved
        fresh = Planar3PSim(DESIGN, pose, MODE, **kwargs)
        assert sim.get_state() == fresh.get_state()
        assert trace(sim, commands) == trace(fresh, commands)


def test_a_reset_after_a_breakdown_is_the_new_build():
    """Non-finite bodies (a failed projection) are forgotten too."""
    poses = starts(2)
    sim = Planar3PSim(DESIGN, poses[0], MODE, **MODELS["projected"])
    for body in (sim.platform, *sim.legs):
        body.position = (math.nan, math.inf)
        body.velocity = (math.nan, 1e300)
    sim.reset(poses[1], MODE)
    fresh = Planar3PSim(DESIGN, poses[1], MODE, **MODELS["projected"])
    commands = np.full((10, 3), 0.01)
    assert trace(sim, commands) == trace(fresh, commands)


def test_without_the_c_api_a_reset_rebuilds_the_same_model(monkeypatch):
    monkeypatch.setattr(Planar3PSim, "use_fast_path", False)
    poses = starts(2)
    sim = Planar3PSim(DESIGN, poses[0], MODE, **MODELS["projected"])
    sim.step((0.01, 0.0, -0.01))
    sim.reset(poses[1], MODE)
    assert not sim.moved
    fresh = Planar3PSim(DESIGN, poses[1], MODE, **MODELS["projected"])
    commands = np.full((5, 3), 0.01)
    assert trace(sim, commands) == trace(fresh, commands)


@pytest.mark.parametrize(
    "pose", [(math.nan, 0.3, 0.0), (0.0, 0.0), (100.0, 100.0, 0.0)], ids=["nan", "short", "far"]
)
def test_a_rejected_reset_changes_nothing(pose):
    poses = starts(1)
    sim = Planar3PSim(DESIGN, poses[0], MODE, **MODELS["projected"])
    sim.step((0.01, 0.0, -0.01))
    before = (sim.state, sim.get_state(), sim.body_values())
    with pytest.raises(ValueError):
        sim.reset(pose, MODE)
    assert (sim.state, sim.get_state(), sim.body_values()) == before


def test_a_closed_simulation_cannot_be_reset():
    poses = starts(2)
    sim = Planar3PSim(DESIGN, poses[0], MODE)
    sim.close()
    assert sim.closed
    with pytest.raises(ValueError, match="closed"):
        sim.reset(poses[1], MODE)


# ------------------------------------------------------------ a reset onto another machine
def machines(n: int, randomization: DynamicsRandomization) -> list:
    """``n`` machines drawn around ``DESIGN`` (fixed seed) that reach the test's starts."""
    rng = np.random.default_rng(11)
    out = []
    while len(out) < n:
        m = randomization.sample(DESIGN, rng)
        if all(kinematics.inverse(m.design, p, MODE).reachable for p in starts(n)):
            out.append(m)
    return out


@pytest.mark.parametrize("model", ["projected", "unprojected"])
def test_a_reset_onto_another_machine_is_its_new_build_bit_for_bit(model):
    """A machine drawn per episode (``Planar3PReal-v0``'s ranges: geometry, masses, force
    limit, friction, lag, tilt) is set on the kept model, not rebuilt; the result is the new
    build of that machine, bit for bit, whatever the model went through before."""
    kwargs = {k: v for k, v in MODELS[model].items() if k != "dynamics"}
    poses = starts(5)
    drawn = machines(len(poses), REALISTIC_RANDOMIZATION)
    rng = np.random.default_rng(5)
    sim = Planar3PSim(drawn[0].design, poses[0], MODE, dynamics=drawn[0].dynamics, **kwargs)
    for k, (pose, m) in enumerate(zip(poses[1:], drawn[1:], strict=True)):
        for c in rng.uniform(-1.0, 1.0, (25, 3)) * DESIGN.max_speed:
            sim.step(c)
        # Then one slider into an end stop (the grooves' and stops' numbers count only there).
        push = np.zeros((80, 3))
        push[:, k % 3] = (-1.0) ** k * DESIGN.max_speed
        commands = np.concatenate([rng.uniform(-0.5, 0.5, (20, 3)) * DESIGN.max_speed, push])
        sim.reset(pose, MODE, design=m.design, dynamics=m.dynamics)
        assert sim.moved and sim.design is m.design
        fresh = Planar3PSim(m.design, pose, MODE, dynamics=m.dynamics, **kwargs)
        assert sim.get_state() == fresh.get_state()
        assert trace(sim, commands) == trace(fresh, commands)
    # and back to the nominal, ideal machine (no friction: other constraints, rebuilt)
    sim.reset(poses[0], MODE, design=DESIGN)
    assert not sim.moved and sim.dynamics is None
    fresh = Planar3PSim(DESIGN, poses[0], MODE, **kwargs)
    commands = np.full((10, 3), 0.01)
    assert trace(sim, commands) == trace(fresh, commands)


def test_a_rejected_machine_changes_nothing():
    poses = starts(2)
    sim = Planar3PSim(DESIGN, poses[0], MODE, **MODELS["imperfect"])
    sim.step((0.01, 0.0, -0.01))
    before = (sim.state, sim.get_state(), sim.body_values(), sim.design, sim.dynamics)
    unstable = {"slider_viscous": 1e6}  # explicit viscous force unstable at this step
    for kwargs, match in (
        ({"dynamics": {"slider_coulomb": 0.1}}, "only with a design"),
        ({"design": "fig8"}, "design must be a Design"),
        ({"design": DESIGN, "dynamics": unstable}, "slider_viscous"),
        ({"design": DESIGN, "dynamics": {"bogus": 1.0}}, "bogus"),
        ({"design": DESIGN.with_(rail_origins=(1.0, 1.0, 1.0))}, "not reachable"),  # moved away
    ):
        with pytest.raises(ValueError, match=match):
            sim.reset(poses[1], MODE, **kwargs)
        assert (sim.state, sim.get_state(), sim.body_values(), sim.design, sim.dynamics) == (before)
