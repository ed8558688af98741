"""Planar3PAssemblyChange-v0: API checks, sampling and its feasibility checks, the crossing, the
signed servo forces of the fidelity study, bad input."""

from __future__ import annotations

import numpy as np
import pytest
from task_helpers import play_episode

import planar3p_gym  # noqa: F401
from planar3p_agents.controllers.crossing import CrossingController
from planar3p_agents.evaluation.crossing_fidelity import _ServoReader, crossing_fidelity
from planar3p_gym import Design
from planar3p_gym.envs.assembly_change import Planar3PAssemblyChangeEnv
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.scalar_kinematics import ConfigurationMeasures
from planar3p_gym.machine.statics import holding_forces
from planar3p_gym.sim.physics import Planar3PSim
from planar3p_gym.tasks import sampling as task
from planar3p_gym.tasks.assembly_change import CrossingLimits, crossing_path

ENV_ID = "Planar3PAssemblyChange-v0"


def test_many_resets_give_opposite_assembly_modes(env):
    design = env.unwrapped.design
    assert design.gravity == 0.0  # the id's default design (see the task's docstring)
    for seed in range(20):
        obs, info = env.reset(seed=seed)
        assert env.observation_space.contains(obs) and np.isfinite(obs).all()
        spec = info["episode_spec"]
        mode = tuple(spec["working_mode"])
        start, target = np.array(spec["start"]), np.array(spec["target"])
        asm = [
            int(kinematics.assembly_mode(design, p, kinematics.inverse(design, p, mode).rho))
            for p in (start, target)
        ]
        assert asm[0] == -asm[1] == info["assembly_mode"]
        assert info["target_assembly"] == asm[1] and obs[34] == asm[1]
        assert not info["in_target_assembly"] and info["crossings"] == 0
        # signed parallel margin: sign det A times the margin
        assert np.sign(obs[35]) == asm[0]
        assert abs(abs(obs[35]) - info["parallel_margin"]) < 1e-6
        ok, reason = crossing_path(design, start, target, mode, CrossingLimits())
        assert ok, reason


def test_crossing_does_not_end_the_episode_and_is_counted(env):
    infos = play_episode(env, CrossingController.from_env(env), seed=4)
    seen, info = [i["assembly_mode"] for i in infos], infos[-1]
    assert info["termination_reason"] == "success" and info["is_success"]
    assert info["crossings"] >= 1 and info["in_target_assembly"]
    assert seen[-1] == info["target_assembly"] == -seen[0] or seen[0] == 0


def test_infeasible_requests_raise(env):
    _, info = env.reset(seed=0)
    spec = info["episode_spec"]
    with pytest.raises(ValueError, match="same assembly mode"):
        env.reset(options={**spec, "target": spec["start"]})
    with pytest.raises(ValueError, match="not reachable"):
        env.reset(options={**spec, "start": [3.0, 0.1, 0.0]})


def test_gravity_in_the_plane_is_rejected_at_construction():
    with pytest.raises(ValueError, match="too few feasible assembly changes"):
        # (On the unprojected model; see the closing note of the layout issue: on the exact
        # machine the simulated demonstration crossings under gravity pass the check.)
        Planar3PAssemblyChangeEnv(design=Design.fig8(), projection=False)


def test_reward_has_no_parallel_barrier(env):
    env.reset(seed=2)
    task = env.unwrapped.task
    kwargs = dict(errors=(0.0, 0.0), action=(0.0, 0.0, 0.0), success=False, failure=False)
    near_parallel = ConfigurationMeasures(0.0, 0.5, 0, (0.0, 0.0, 0.0))
    assert task.reward_terms(measures=near_parallel, **kwargs)["singularity"] == 0.0
    near_serial = ConfigurationMeasures(0.5, 0.001, 1, (0.0, 0.0, 0.0))
    assert task.reward_terms(measures=near_serial, **kwargs)["singularity"] < 0.0


def test_signed_servo_forces_match_statics():
    """The fidelity study's signed servo impulses: holding a pose at rest under gravity, the
    servos' forces are the statics' holding forces (virtual work), signs included."""
    design = Design.fig8()
    mode = (1, 1, -1)
    poses, _ = task.sample_poses(design, mode, np.random.default_rng(0), task.TaskConfig())
    pose = poses[0]
    sim = Planar3PSim(design, pose, mode)
    sim._fast = None
    readers = [_ServoReader(s) for s in sim.servos]
    for _ in range(25):
        sim.step([0.0, 0.0, 0.0])
    h = sim.dt / sim.substeps
    forces = np.array([r.impulse_x() / h for r in readers])
    expected = holding_forces(design, pose, mode)
    np.testing.assert_allclose(forces, expected, rtol=0.02, atol=0.02)


def test_crossing_fidelity_with_projection_closes_the_loop(env):
    """With the projected physics the loop closes exactly through the crossing (closure error
    below the projection's tolerance), and the energy booked is finite and consistent."""
    f = crossing_fidelity(env, CrossingController.from_env(env), 3)
    assert f["success"] == 1.0 and f["crossings"] >= 1
    assert f["max_closure_error"] < 1e-9
    assert np.isfinite([f["servo_work"], f["energy_gap"], f["projection_energy"]]).all()
    assert f["servo_abs_work"] >= abs(f["servo_work"])


def test_gravity_pushes_along_the_free_motion_at_every_singularity():
    """On the default design no parallel singularity of mode (1, 1, 1) (serial margin >= 0.1)
    is gravity-neutral: the weight has a component along the free motion, so no singular pose
    can be held at rest (a quasi-static crossing does not exist).  The reported point is
    singular: det A vanishes there."""
    from planar3p_gym.tasks.assembly_change import gravity_alignment

    design = Design.fig8()
    cos, (y, theta) = gravity_alignment(design, (1, 1, 1), thetas=241, heights=401)
    assert 0.05 < cos < 1.0
    pose = np.array([0.0, y, theta])
    rho = kinematics.inverse(design, pose, (1, 1, 1)).rho
    rho = rho - rho.min() + 0.01  # shift x into the stroke (det A does not depend on x)
    pose[0] = rho[0] - kinematics.inverse(design, np.array([0.0, y, theta]), (1, 1, 1)).rho[0]
    assert float(kinematics.parallel_margin(design, pose, rho)) < 1e-6
