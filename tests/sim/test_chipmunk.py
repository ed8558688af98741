"""The compiled control step (planar3p_gym.sim.chipmunk): the same simulation as its parts called
one by one, for one simulation and for a batch, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from projection_helpers import step_in_parts

from planar3p_gym import Design
from planar3p_gym.sim import chipmunk
from planar3p_gym.sim.physics import FOLLOWING_ERROR_LIMIT, Planar3PSim
from planar3p_gym.tasks import sampling as task

DESIGN = Design.fig8()
MODE = (1, 1, -1)


def starts(n: int, seed: int = 5) -> np.ndarray:
    poses, _ = task.sample_poses(DESIGN, MODE, np.random.default_rng(seed), task.TaskConfig())
    return poses[:n]


def projected(pose: np.ndarray) -> Planar3PSim:
    return Planar3PSim(DESIGN, pose, MODE, substeps=1, iterations=10, projection=True)


def commands(n: int, seed: int) -> np.ndarray:
    """Slider commands at full speed (m/s): every slider driven one way for ``n // 2`` steps
    (at 0.2 m/s for 1.5 s or more, past its stroke: the sliders reach their end stops and the
    servos pushing them saturate), then bang-bang."""
    rng = np.random.default_rng(seed)
    out = DESIGN.max_speed * rng.choice([-1.0, 1.0], size=(n, 3))
    out[: n // 2] = out[0]
    return out


def test_chipmunk_calls_are_compiled_on_the_pinned_pymunk():
    assert chipmunk.AVAILABLE
    assert len(chipmunk.FUNCTIONS) == 7 and all(chipmunk.FUNCTIONS)
    sim = projected(starts(1)[0])
    assert sim._fast is not None
    assert sim._fast.handles.tolist()[0] == chipmunk.address(sim.space._space)
    fast = sim._fast  # the row in HANDLE_FIELDS order
    assert sim._fast.handles.tolist() == [
        chipmunk.address(p) for p in (fast.space, *fast.servos, fast.read.request, fast.read.array)
    ]
    assert len(fast.handles) == len(chipmunk.HANDLE_FIELDS)


def test_the_compiled_step_is_its_parts_bit_for_bit(monkeypatch):
    """:func:`chipmunk.step_projected` against read, advance, project and write called from
    Python (what ``tests/projection_helpers.py`` records with): the same states and bodies."""
    pose = starts(1)[0]
    runs = []
    for parts in (False, True):
        if parts:
            monkeypatch.setattr(chipmunk, "step_projected", step_in_parts())
        sim = projected(pose)
        runs.append([(sim.step(c), sim.body_values()) for c in commands(150, 7)])
    assert [s for s, _ in runs[0]] == [s for s, _ in runs[1]]
    assert [b for _, b in runs[0]] == [b for _, b in runs[1]]  # pymunk's own bodies
    assert any(any(s.saturated) for s, _ in runs[0])


def test_write_then_read_leaves_every_body_as_it_was():
    sim = projected(starts(1)[0])
    for c in commands(20, 2):
        sim.step(c)
    fns, handles, readout = chipmunk.FUNCTIONS, sim._fast.handles, sim._fast.readout
    chipmunk.read_bodies(fns, handles)
    before = readout[:60].copy()
    for _ in range(3):
        chipmunk.write_bodies(fns, handles)
        readout[:60] = np.nan
        chipmunk.read_bodies(fns, handles)
        assert readout[:60].tobytes() == before.tobytes()


@pytest.mark.parametrize("rows", [[0, 1, 2, 3], [2, 0]])
def test_the_batch_step_is_each_simulations_step_bit_for_bit(rows):
    """:func:`chipmunk.advance_batch` over simulations whose readouts live in one array, against
    the same simulations stepped one by one (:meth:`Planar3PSim.step`); rows not stepped are
    left alone."""
    poses, n = starts(4), 4
    singles = [projected(p) for p in poses]
    batch = [projected(p) for p in poses]
    readouts = np.zeros((n, 132))
    handles = np.zeros((n, 6), dtype=np.uintp)
    keep = []
    for i, sim in enumerate(batch):
        # Each batch simulation's request over a row of the shared readouts (as the vector env).
        read = chipmunk.body_readout(readouts[i])
        keep.append(read)
        handles[i] = chipmunk.handle_row(sim._fast.space, sim._fast.servos, read)
        chipmunk.read_bodies(chipmunk.FUNCTIONS, handles[i])
    sim0, initial = batch[0], readouts.copy()
    for c in commands(60, 11).reshape(20, 3, 3):
        v = np.array([c[k % 3] for k in range(len(rows))])
        forces, saturated, states, closure = chipmunk.advance_batch(
            chipmunk.FUNCTIONS, handles, np.array(rows), v, sim0._h, sim0.substeps,
            sim0._force_limit, readouts, sim0._projector.constants, FOLLOWING_ERROR_LIMIT,
        )  # fmt: skip
        for k, i in enumerate(rows):
            s = singles[i].step(v[k])
            assert states[:3, k].tolist() == list(s.rho)
            assert states[3:6, k].tolist() == list(s.rho_dot)
            assert states[6:9, k].tolist() == list(s.pose)
            assert states[9:15, k].tolist() == [*s.twist, *s.leg_angles]
            assert closure[k] == s.closure_error
            assert tuple(saturated[:, k].tolist()) == s.saturated
            assert (forces[k, :3] * sim0._force_scale).tolist() == list(s.actuator_forces)
            assert readouts[i, :60].tolist() == singles[i]._fast.readout.tolist()
    for i in set(range(n)) - set(rows):
        assert readouts[i].tolist() == initial[i].tolist()  # not stepped: left alone


@pytest.mark.parametrize(
    "memory",
    [np.zeros(60, dtype=np.float32), np.zeros((2, 60)), np.zeros(120)[::2]],
    ids=["float32", "2-d", "strided"],
)
def test_a_body_readout_refuses_memory_pymunk_cannot_fill(memory):
    """pymunk writes doubles through one pointer: only a contiguous 1-D float64 array will do."""
    with pytest.raises(ValueError, match="C-contiguous 1-D float64"):
        chipmunk.body_readout(memory)


def test_a_body_readout_reads_every_body_into_its_memory():
    """A request over numpy memory reads the same numbers as the simulation's own."""
    sim = projected(starts(1)[0])
    read = chipmunk.body_readout(np.full(132, np.nan))
    handles = chipmunk.handle_row(sim._fast.space, sim._fast.servos, read)
    chipmunk.read_bodies(chipmunk.FUNCTIONS, handles)
    n = read.array.num
    assert n == 6 * (len(sim.space.bodies) + 1)  # six per body, and the space's static body
    assert read.memory[:n].tolist() == sim._batch_values(sim._fast)
    assert np.isnan(read.memory[n:]).all()  # nothing past the bodies' numbers


#: A machine with viscous friction on the sliders and the joints, and every other imperfection.
VISCOUS = {
    "slider_coulomb": 0.5,
    "joint_coulomb": 0.01,
    "slider_viscous": 2.0,
    "joint_viscous": 1e-3,
    "servo_lag": 0.03,
    "gravity_tilt": 0.01,
    "inertia_scale": 1.1,
}


@pytest.mark.parametrize("dynamics", [VISCOUS, {"slider_viscous": 5.0}, {"joint_viscous": 2e-3}])
def test_the_compiled_viscous_step_is_pymunks_bit_for_bit(dynamics):
    """:func:`chipmunk.step_projected_viscous` (the forces of ``_apply_viscous`` written before
    each physics step through the force request) against the same steps through pymunk's API:
    the same states and bodies, into the end stops and out of them."""
    pose = starts(1)[0]
    runs = []
    for compiled in (True, False):
        sim = Planar3PSim(
            DESIGN, pose, MODE, substeps=2, iterations=10, projection=True, dynamics=dynamics
        )
        sim.use_compiled_viscous = compiled
        runs.append([(sim.step(c), sim.body_values()) for c in commands(150, 3)])
    assert runs[0] == runs[1]
    assert any(any(s.saturated) for s, _ in runs[0])


def test_the_force_request_writes_each_bodys_force_and_torque():
    """The force request's layout: ``fx, fy, t`` per body, in readout order."""
    sim = Planar3PSim(DESIGN, starts(1)[0], MODE, projection=True, dynamics=VISCOUS)
    fast = sim._fast
    n = len(sim._bodies)
    fast.applied[: 3 * n] = np.arange(1.0, 3 * n + 1.0)
    chipmunk.write_forces(chipmunk.FUNCTIONS, fast.handles, fast.push_handles)
    for k, body in enumerate(sim._bodies):
        if body.body_type == body.DYNAMIC:
            assert (*body.force, body.torque) == tuple(fast.applied[3 * k : 3 * k + 3])


def test_every_call_into_chipmunk_clears_the_upper_registers_first(monkeypatch):
    """On an x86 CPU with AVX each compiled call into Chipmunk is preceded by ``vzeroupper``
    (read in the assembly of a function compiled here, uncached) and nowhere else is one
    emitted; which CPUs count follows numba's target CPU."""
    from numba import njit, types

    @njit(types.void(types.uintp[:], types.uintp[:], types.float64))
    def step(fns, handles, h):
        chipmunk._call_pd(fns[0], handles[0], h)

    asm = step.inspect_asm(step.signatures[0])
    assert ("vzeroupper" in asm) == chipmunk.CLEARS_UPPER
    if chipmunk.CLEARS_UPPER:  # the clearing precedes the call
        body = asm[asm.index("vzeroupper") :]
        assert "call" in body
    monkeypatch.setattr(chipmunk.platform, "machine", lambda: "aarch64")
    assert not chipmunk._compiles_avx()
    monkeypatch.setattr(chipmunk.platform, "machine", lambda: "x86_64")
    monkeypatch.setattr(chipmunk.numba_config, "CPU_NAME", "generic")
    monkeypatch.setattr(chipmunk.numba_config, "CPU_FEATURES", "+sse2")
    assert not chipmunk._compiles_avx()
    monkeypatch.setattr(chipmunk.numba_config, "CPU_FEATURES", "+sse2,+avx")
    assert chipmunk._compiles_avx()
    monkeypatch.setattr(chipmunk.numba_config, "CPU_NAME", "host")  # the host's own features
    assert chipmunk._compiles_avx() == bool(chipmunk.llvm.get_host_cpu_features().get("avx"))
