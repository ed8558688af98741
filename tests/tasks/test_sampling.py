"""Task sampling: the fast filters decide as the reference computation (inverse, margins, the
holding forces), so that a seed gives the same episodes."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from planar3p_gym import Design
from planar3p_gym.machine import kinematics
from planar3p_gym.machine.statics import holding_forces
from planar3p_gym.tasks import sampling as task

DESIGN = Design.fig8()
CFG = task.TaskConfig()
MODES = [tuple(m) for m in kinematics.ALL_MODES.tolist()]
CONFIGS = {
    "default": CFG,
    "tight": replace(CFG, min_parallel_margin=0.1, min_serial_margin=0.4, travel_margin=0.1),
    "loose": replace(CFG, min_parallel_margin=0.0, min_serial_margin=0.0, travel_margin=0.0),
}


def rectangle_poses(design: Design, n: int, rng: np.random.Generator) -> np.ndarray:
    x0, x1, _, h = design.search_rectangle
    u = rng.random((n, 3))
    return np.column_stack([x0 + (x1 - x0) * u[:, 0], h * u[:, 1], np.pi * (2 * u[:, 2] - 1)])


def reference_acceptable(design, poses, mode, cfg):
    """The filter as written before the fast path: inverse, margins, holding forces."""
    rho, _ = kinematics.inverse(design, poses, mode)
    lo, hi = cfg.travel_margin * design.stroke, (1.0 - cfg.travel_margin) * design.stroke
    inside = np.all((rho >= lo) & (rho <= hi), axis=-1)
    ok = np.zeros(len(poses), dtype=bool)
    det = np.zeros(len(poses))
    if inside.any():
        pm, sm, d = kinematics.margins(design, poses[inside], rho[inside])
        ok[inside] = (pm >= cfg.min_parallel_margin) & (sm >= cfg.min_serial_margin)
        det[inside] = d
    if ok.any():
        forces = holding_forces(design, poses[ok], mode)
        ok[ok] = np.abs(forces).max(axis=-1) <= cfg.max_holding_force * design.max_force
    return ok, det


def reference_path_is_clear(design, start, targets, mode, assembly, cfg):
    path = task.interpolate(start[None, :], targets, cfg.path_points)
    rho, reachable = kinematics.inverse(design, path, np.asarray(mode, dtype=np.float64))
    ok = reachable.all(axis=-1)
    if ok.any():
        pm, sm, det = kinematics.margins(design, path[ok], rho[ok])
        ok[ok] = (
            (pm >= cfg.path_parallel_margin).all(-1)
            & (sm >= cfg.path_serial_margin).all(-1)
            & (det == assembly).all(-1)
        )
    return ok


def reference_pair_ok(design, start, targets, mode, assembly, cfg):
    far = task.pose_distance(start[None, :], targets, design.characteristic_length)
    far = far >= cfg.min_distance
    if not cfg.clear_path or not far.any():
        return far
    ok = far.copy()
    ok[far] = reference_path_is_clear(design, start, targets[far], mode, assembly, cfg)
    return ok


def reference_sample_pair(design, mode, rng, cfg, sampler, max_tries=100):
    """``sample_pair`` without a given start or target, checking every candidate."""
    for _ in range(max_tries):
        s, det = sampler.draw(rng)
        cands = sampler.draw_many(rng, det, 8)
        ok = reference_pair_ok(design, s, cands, mode, det, cfg)
        if ok.any():
            return s, cands[int(np.argmax(ok))]
    raise ValueError("no pair")


@pytest.mark.parametrize("cfg_name", sorted(CONFIGS))
@pytest.mark.parametrize("mode", MODES, ids=str)
def test_acceptable_matches_the_reference(mode, cfg_name):
    cfg = CONFIGS[cfg_name]
    poses = rectangle_poses(DESIGN, 4096, np.random.default_rng(11))
    ok, det = task._acceptable(DESIGN, poses, np.asarray(mode, dtype=np.float64), cfg)
    want_ok, want_det = reference_acceptable(DESIGN, poses, mode, cfg)
    np.testing.assert_array_equal(ok, want_ok)
    np.testing.assert_array_equal(det[ok], want_det[ok])
    assert det.dtype == np.float64


@settings(max_examples=40)
@given(
    mode=st.sampled_from(MODES),
    seed=st.integers(0, 2**32 - 1),
    path_parallel=st.floats(0.0, 0.2),
    path_serial=st.floats(0.0, 0.5),
    clear_path=st.booleans(),
)
def test_first_ok_is_the_first_candidate_the_reference_accepts(
    mode, seed, path_parallel, path_serial, clear_path
):
    cfg = replace(
        CFG,
        path_parallel_margin=path_parallel,
        path_serial_margin=path_serial,
        clear_path=clear_path,
    )
    rng = np.random.default_rng(seed)
    sampler = task.PoseSampler(DESIGN, mode, CFG)
    for _ in range(5):
        start, det = sampler.draw(rng)
        cands = sampler.draw_many(rng, det, 8)
        # sometimes the other assembly mode, or a candidate next to the start
        assembly = -det if rng.random() < 0.2 else det
        cands[0] = start + 0.01 * rng.random(3) if rng.random() < 0.3 else cands[0]
        want = reference_pair_ok(DESIGN, start, cands, mode, assembly, cfg)
        got = task._first_ok(DESIGN, start, cands, mode, assembly, cfg)
        assert got == (int(np.argmax(want)) if want.any() else None)
        if cfg.clear_path:
            np.testing.assert_array_equal(
                task.path_is_clear(DESIGN, start, cands, mode, assembly, cfg),
                reference_path_is_clear(DESIGN, start, cands, mode, assembly, cfg),
            )


@pytest.mark.parametrize("mode", MODES, ids=str)
def test_sample_pair_gives_the_reference_pairs_and_random_stream(mode):
    got_rng, want_rng = np.random.default_rng(5), np.random.default_rng(5)
    got_sampler = task.PoseSampler(DESIGN, mode, CFG)
    want_sampler = task.PoseSampler(DESIGN, mode, CFG)
    for _ in range(40):
        s, t = task.sample_pair(DESIGN, mode, got_rng, CFG, sampler=got_sampler)
        ws, wt = reference_sample_pair(DESIGN, mode, want_rng, CFG, want_sampler)
        np.testing.assert_array_equal(s, ws)
        np.testing.assert_array_equal(t, wt)
    assert got_rng.bit_generator.state == want_rng.bit_generator.state


def test_sample_pair_with_a_given_start_or_target():
    mode = (1, 1, -1)
    rng = np.random.default_rng(2)
    start, target = task.sample_pair(DESIGN, mode, rng, CFG)
    asm = float(
        kinematics.assembly_mode(DESIGN, start, kinematics.inverse(DESIGN, start, mode).rho)
    )
    s, t = task.sample_pair(DESIGN, mode, rng, CFG, start=start)
    assert s is start
    assert reference_pair_ok(DESIGN, s, t[None], mode, asm, CFG)[0]
    s, t = task.sample_pair(DESIGN, mode, rng, CFG, target=target)
    assert t is target
    assert reference_pair_ok(DESIGN, s, t[None], mode, asm, CFG)[0]


def test_interpolate_steps():
    a, b = np.array([0.1, 0.2, 3.0]), np.array([[0.2, 0.1, -3.0]])
    path = task.interpolate(a[None], b, 5)
    assert path.shape == (1, 5, 3) and path.flags.writeable
    np.testing.assert_array_equal(path[0, :, 0], a[0] + np.linspace(0, 1, 5) * (b[0, 0] - a[0]))
    with pytest.raises(TypeError):
        task.interpolate(a[None], b, 5.0)  # type: ignore[arg-type]


def test_a_larger_budget_draws_the_same_poses():
    """``max_batches`` only bounds the search (every sampler loop has a budget): where the
    default search finds poses, a larger budget consumes the stream identically."""
    for mode in MODES:
        a = task.sample_poses(DESIGN, mode, np.random.default_rng(8), CFG)
        b = task.sample_poses(DESIGN, mode, np.random.default_rng(8), CFG, max_batches=2000)
        np.testing.assert_array_equal(a[0], b[0])
        np.testing.assert_array_equal(a[1], b[1])


def test_check_mode_accepts_modes_with_pairs_and_explains_the_others():
    for mode in MODES:  # every mode of the default design has pairs
        task.check_mode(DESIGN, mode, CFG)
        assert task.has_pairs(DESIGN, mode, CFG)
    fig7 = Design.fig7()
    with pytest.raises(
        ValueError,
        match=r"\(1, 1, 1\) of this design has no (pose|start/target pair) .*"
        r"(\d+) acceptable\)",
    ):
        task.check_mode(fig7, (1, 1, 1), CFG)
    assert not task.has_pairs(fig7, (1, 1, 1), CFG)
    apart = replace(CFG, min_distance=5.0)  # poses, but none 5 m apart
    with pytest.raises(ValueError, match=r"no start/target pair .* min_distance apart"):
        task.check_mode(DESIGN, (1, 1, -1), apart)


# ---------------------------------------------------------------- near-singular training pairs
def _path_checks(design: Design, start, target, mode, cfg: task.TaskConfig) -> tuple[bool, bool]:
    """(reachable with the path serial margin, clear of ``near_singular_margin`` in the start's
    assembly mode) of the straight path, on the task's path points."""
    det = float(
        kinematics.assembly_mode(design, start, kinematics.inverse(design, start, mode).rho)
    )
    path = task.interpolate(start[None, :], target[None, :], cfg.path_points)
    m = np.asarray(mode, dtype=np.float64)
    reachable = kinematics.screen_paths(design, path, m, min_serial=cfg.path_serial_margin)[0]
    clear = kinematics.screen_paths(
        design, path, m, min_parallel=cfg.near_singular_margin, assembly=det
    )[0]
    return bool(reachable), bool(clear)


def test_near_singular_pairs_come_within_the_margin():
    """With near_singular_fraction = 1 every drawn pair is of the benchmark's hard kind: same
    assembly mode, min_distance apart, acceptable ends, a path reachable with the serial margin
    that comes within near_singular_margin of a parallel singularity (the clear-path rule
    would have refused every one of them)."""
    design, mode = Design.fig8(), (1, 1, -1)
    cfg = task.TaskConfig(near_singular_fraction=1.0, near_singular_margin=0.01)
    rng = np.random.default_rng(5)
    sampler = task.PoseSampler(design, mode, cfg)
    for _ in range(4):
        s, t = task.sample_pair(design, mode, rng, cfg, sampler=sampler)
        ok, dets = task._acceptable(design, np.array([s, t]), np.asarray(mode, float), cfg)
        assert ok.all() and dets[0] == dets[1]
        assert task.pose_distance(s, t, design.characteristic_length) >= cfg.min_distance
        assert _path_checks(design, s, t, mode, cfg) == (True, False)
        assert not task.path_is_clear(design, s, t[None, :], mode, dets[0], cfg)[0]


def test_near_singular_fraction_mixes_and_replays():
    """A fraction of 0.5 gives both kinds of pair; the same seed gives the same pairs; the
    default (0) leaves the draws of the plain task untouched (an extra random number would
    shift them: pinned by tests/sim/test_unprojected_regression.py as well)."""
    design, mode = Design.fig8(), (1, 1, -1)
    cfg = task.TaskConfig(near_singular_fraction=0.5)

    def draws(c: task.TaskConfig, seed: int, n: int) -> list[tuple[np.ndarray, np.ndarray]]:
        rng, sampler = np.random.default_rng(seed), task.PoseSampler(design, mode, c)
        return [task.sample_pair(design, mode, rng, c, sampler=sampler) for _ in range(n)]

    pairs = draws(cfg, 3, 12)
    kinds = {_path_checks(design, s, t, mode, cfg)[1] for s, t in pairs}
    assert kinds == {True, False}
    again = draws(cfg, 3, 12)
    np.testing.assert_array_equal(np.array(pairs), np.array(again))
    plain = draws(task.TaskConfig(), 3, 3)
    zero = draws(task.TaskConfig(near_singular_fraction=0.0, near_singular_margin=0.02), 3, 3)
    np.testing.assert_array_equal(np.array(plain), np.array(zero))


@pytest.mark.parametrize(
    "kwargs",
    [
        {"near_singular_fraction": 1.5},
        {"near_singular_fraction": -0.1},
        {"near_singular_fraction": float("nan")},
        {"near_singular_margin": 1.0},
        {"near_singular_margin": -0.01},
    ],
)
def test_bad_near_singular_settings_raise(kwargs):
    with pytest.raises(ValueError, match="near_singular"):
        task.TaskConfig(**kwargs)


def test_a_given_assembly_mode_needs_a_given_start_and_a_sign():
    """``sample_pair(assembly=...)``: the assembly mode of a given start, +1 or -1; the same
    pair as when it is computed."""
    start, _ = task.sample_pair(DESIGN, (1, 1, -1), np.random.default_rng(0), CFG)
    rho = kinematics.inverse(DESIGN, start, (1, 1, -1)).rho
    det = float(kinematics.assembly_mode(DESIGN, start, rho))
    a = task.sample_pair(DESIGN, (1, 1, -1), np.random.default_rng(1), CFG, start=start)
    b = task.sample_pair(
        DESIGN, (1, 1, -1), np.random.default_rng(1), CFG, start=start, assembly=det
    )
    np.testing.assert_array_equal(a[1], b[1])
    for kwargs in ({"start": start, "assembly": 0.5}, {"assembly": 1.0}):
        with pytest.raises(ValueError, match="assembly must be"):
            task.sample_pair(DESIGN, (1, 1, -1), np.random.default_rng(1), CFG, **kwargs)


# ------------------------------------------------------------------ detours in every mode
NO_DETOURS = (1, 1, 1)  # the straight slider line solves every pair of this mode


def test_detour_fraction_in_a_mode_without_detours_is_refused_when_the_env_is_made():
    """Every reset spent its 200-start budget (1-1.8 s), then silently returned an ordinary
    pair; now the setting is refused, when the env is made and in a running env."""
    import gymnasium as gym

    import planar3p_gym  # noqa: F401

    assert not task.has_detours(Design.fig8(), NO_DETOURS, task.TaskConfig())
    assert task.has_detours(Design.fig8(), (1, 1, -1), task.TaskConfig())
    for env_id in ("Planar3P-v0", "Planar3PGoal-v0"):
        with pytest.raises(ValueError, match=r"detour_fraction \(0\.5\).*\(1, 1, 1\)"):
            gym.make(env_id, working_mode=NO_DETOURS, task_config={"detour_fraction": 0.5})
    env = gym.make("Planar3P-v0", working_mode=NO_DETOURS).unwrapped
    with pytest.raises(ValueError, match="detour_fraction"):
        env.set_task_config({"detour_fraction": 1.0})
    assert env.task_config.detour_fraction == 0.0


def test_under_random_modes_a_mode_without_detours_draws_its_pair_at_once(monkeypatch):
    """With ``working_mode="random"`` the modes with detours keep them; the others draw an
    ordinary pair without searching (no detour search runs in them)."""
    import gymnasium as gym

    import planar3p_gym  # noqa: F401

    searched = []
    search = task._detour_pair
    monkeypatch.setattr(
        task, "_detour_pair", lambda d, m, *a: searched.append(tuple(m)) or search(d, m, *a)
    )
    env = gym.make("Planar3P-v0", working_mode="random", task_config={"detour_fraction": 1.0})
    design, cfg = Design.fig8(), task.TaskConfig()
    every = [tuple(m) for m in kinematics.ALL_MODES.tolist()]
    lacking = {m for m in every if not task.has_detours(design, m, cfg)}  # (cached from here)
    searched.clear()  # (the fixed-seed searches of the checks)
    modes = [env.reset(seed=seed)[1]["working_mode"] for seed in range(40)]
    assert set(modes) & lacking and set(modes) - lacking  # both kinds were drawn
    assert searched and not set(searched) & lacking


# ------------------------------------------------------------------ the kind of pair, reported
@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_draw_pair_reports_the_kind_it_drew(seed):
    """``draw_pair``'s kind is what the pair is: a near-singular one passes the near-singular
    test, an ordinary one the clear-path rule; the poses are those of ``sample_pair``."""
    design, mode = Design.fig8(), (1, 1, -1)
    cfg = task.TaskConfig(near_singular_fraction=0.5)

    def draw(fn):
        rng, sampler = np.random.default_rng(seed), task.PoseSampler(design, mode, cfg)
        return fn(design, mode, rng, cfg, sampler=sampler)

    s, t, kind = draw(task.draw_pair)
    np.testing.assert_array_equal(np.array([s, t]), np.array(draw(task.sample_pair)))
    assert kind in ("near_singular", "ordinary", "near_singular_not_found")
    _, dets = task._acceptable(design, np.array([s, t]), np.asarray(mode, float), cfg)
    clear = task.path_is_clear(design, s, t[None, :], mode, dets[0], cfg)[0]
    assert clear == (kind != "near_singular")
    if kind == "near_singular":
        assert _path_checks(design, s, t, mode, cfg) == (True, False)


def test_a_search_that_runs_out_is_reported_not_hidden(monkeypatch):
    """A near-singular or detour search that exhausts its budget gives an ordinary pair and
    says so; given poses are "given"."""
    design, mode = Design.fig8(), (1, 1, -1)
    monkeypatch.setattr(task, "NEAR_SINGULAR_STARTS", 0)
    monkeypatch.setattr(task, "DETOUR_RESET_STARTS", 0)
    for cfg, kind in (
        (task.TaskConfig(near_singular_fraction=1.0), "near_singular_not_found"),
        (task.TaskConfig(detour_fraction=1.0), "detour_not_found"),
    ):
        rng = np.random.default_rng(2)
        s, t, got = task.draw_pair(design, mode, rng, cfg)
        assert got == kind
        _, dets = task._acceptable(design, np.array([s, t]), np.asarray(mode, float), cfg)
        assert task.path_is_clear(design, s, t[None, :], mode, dets[0], cfg)[0]
        assert task.draw_pair(design, mode, rng, cfg, start=s, target=t)[2] == "given"


@pytest.mark.parametrize("env_id", ["Planar3P-v0", "Planar3PGoal-v0"])
def test_the_episode_spec_names_the_pair_kind_and_replays_it(env_id, monkeypatch):
    """With a share of special pairs the spec says which kind each episode has (a search that
    ran out included) and a replay keeps it; the default spec has no such entry; a bad or
    unanchored ``pair`` option is refused before anything changes."""
    import gymnasium as gym

    import planar3p_gym  # noqa: F401

    assert "pair" not in gym.make(env_id).reset(seed=0)[1]["episode_spec"]
    env = gym.make(env_id, task_config={"near_singular_fraction": 1.0})
    spec = env.reset(seed=4)[1]["episode_spec"]
    assert spec["pair"] == "near_singular"
    assert env.reset(options=spec)[1]["episode_spec"] == spec
    monkeypatch.setattr(task, "NEAR_SINGULAR_STARTS", 0)
    assert env.reset(seed=4)[1]["episode_spec"]["pair"] == "near_singular_not_found"
    before = env.unwrapped.episode_spec
    for options, match in (
        ({**spec, "pair": "easy"}, "option pair must be one of"),
        ({"pair": "ordinary"}, "give start and target"),
    ):
        with pytest.raises(ValueError, match=match):
            env.reset(options=options)
        assert env.unwrapped.episode_spec == before


# ------------------------------------------------------------------ refill batches by yield
def test_refills_are_sized_by_the_mode_s_yield():
    """A default refill is one default batch in every mode whose batch yields MIN_YIELD poses
    (the default streams are those of one batch a refill); a sparse mode's refill is the
    smallest power-of-two multiple expected to yield them; a larger need asks for more, up to
    MAX_BATCH_FACTOR; a batch of a multiple is uniform over the same acceptable poses."""
    design, cfg = Design.fig8(), task.TaskConfig()
    for mode in (tuple(m) for m in kinematics.ALL_MODES.tolist()):
        mean = task.pose_yield(design, mode, cfg)
        assert mean > 0
        for need in (task.MIN_YIELD, 256, 10**6):
            factor = task.refill_batch(design, mode, cfg, need) // task.DEFAULT_BATCH
            assert factor & (factor - 1) == 0 and 1 <= factor <= task.MAX_BATCH_FACTOR
            assert mean * factor >= need or factor == task.MAX_BATCH_FACTOR
            assert factor == 1 or mean * factor / 2 < need
        if mean >= task.MIN_YIELD:
            assert task.refill_batch(design, mode, cfg, task.MIN_YIELD) == task.DEFAULT_BATCH
    sparse = (1, -1, 1)
    assert task.pose_yield(design, sparse, cfg) < task.MIN_YIELD
    big = task.refill_batch(design, sparse, cfg, task.MIN_YIELD)
    poses, _ = task.sample_poses(design, sparse, np.random.default_rng(0), cfg, batch=big)
    ok, _ = task._acceptable(design, poses, np.asarray(sparse, float), cfg)
    assert ok.all() and len(poses) >= 1


def test_a_sampler_copy_shares_its_read_only_poses_and_draws_as_the_original():
    """A deep copy (snapshots, a reset's undo record) and a pickled copy of a sampler hold
    their own pools of the original's pose arrays, which are read-only; each copy then draws
    the same poses as the original from the same stream, and drawing from one leaves the
    others' pools as they were."""
    import copy
    import pickle

    mode = MODES[0]
    sampler = task.PoseSampler(DESIGN, mode, CFG)
    rng = np.random.default_rng(5)
    sampler.draw(rng)
    sampler.push_front(np.array([0.1, 0.05, 0.2]), 1.0)
    pooled = sampler.pooled()
    assert len(pooled) >= 2
    deep, pickled = copy.deepcopy(sampler), pickle.loads(pickle.dumps(sampler))
    for other in (deep, pickled):
        for (p, d), (q, e) in zip(pooled, other.pooled(), strict=True):
            assert not q.flags.writeable and d == e
            np.testing.assert_array_equal(p, q)
    assert deep.pooled()[0][0] is pooled[0][0]  # (shared, not copied)
    state = rng.bit_generator.state
    draws = []
    for s in (sampler, deep, pickled):
        rng.bit_generator.state = state
        draws.append([s.draw(rng)[0] for _ in range(len(pooled) + 3)])  # (a refill on the way)
        assert not draws[-1][0].flags.writeable
    for got in draws[1:]:
        for p, q in zip(draws[0], got, strict=True):
            np.testing.assert_array_equal(p, q)
    untouched = copy.deepcopy(deep)
    untouched_pool = untouched.pooled()
    deep.draw(rng)
    assert len(untouched.pooled()) == len(untouched_pool)
