"""The shipped pretrained policies load by name, act in the environment, say how they were made."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

import planar3p_gym  # noqa: F401
from planar3p_agents.policies import spec as policy_spec
from planar3p_agents.policies.factory import (
    MANIFEST,
    PRETRAINED_DIR,
    TRUSTED_FILES_NOTE,
    PolicyError,
    file_sha256,
    list_pretrained,
    load_policy,
    policy_label,
    run_env_kwargs,
    verify_pretrained,
)
from planar3p_agents.policies.play_envs import observation_kwargs
from planar3p_agents.zoo.layout import shipped_model

SHIPPED = list_pretrained()
#: A shipped policy of ``Planar3P-v0`` (the tests below play it there; the list is sorted by name).
REACH_V0 = "ppo_reach_scratch"


def _record(name: str) -> dict:
    return json.loads(shipped_model(name).provenance.read_text())


def test_a_policy_is_shipped_small_with_its_statistics_and_provenance() -> None:
    assert SHIPPED, "agents/zoo/pretrained/ holds no policy"
    for name in SHIPPED:
        shipped = shipped_model(name)
        assert shipped.model.stat().st_size < 5 * 2**20  # a few MB at most
        assert shipped.stats.is_file()
        record = _record(name)
        command = record["run"]["command"]  # the command that reproduces it (either CLI)
        assert "train.py" in command or command.startswith("planar3p train")


@pytest.mark.parametrize("name", SHIPPED)
def test_pretrained_policy_loads_and_acts(name: str) -> None:
    """Played in the id it was trained on (its provenance), without training-only kwargs but
    with those that change the observation (``travel_goal``)."""
    record = _record(name)
    config = record["run"]["config"]
    env = gym.make(config["env_id"], **observation_kwargs(config.get("env_kwargs")))
    policy = load_policy(f"pretrained:{name}", env=env)
    obs, info = env.reset(seed=11)
    start_error = info["position_error"]
    actions = []
    # The on-off motors move 0.4 mm a step: they get their id's time limit (20 s).
    discrete = not isinstance(env.action_space, gym.spaces.Box)
    steps = env.spec.max_episode_steps if discrete else 250
    state = None  # handed back: a policy may keep its last command there
    for _ in range(steps):
        action, state = policy.predict(obs, state, deterministic=True)
        action = np.asarray(action)
        assert action.shape == (3,) and np.isfinite(action).all()
        actions.append(action)
        obs, _, terminated, truncated, info = env.step(action)
        if terminated or truncated:
            break
    # Deterministic: the same observation gives the same action.
    np.testing.assert_array_equal(
        policy.predict(obs, state, deterministic=True)[0],
        policy.predict(obs, state, deterministic=True)[0],
    )
    # It acts, and brings the gripper much closer to the target (random actions do not).
    assert np.abs(np.array(actions)).max() > 0.05
    if env.unwrapped.task.name == "track":  # T: no target to reach; it follows the reference
        assert info["tracking_rms_error"] < _feedforward_rms(record["run"]["config"]["env_id"])
    else:
        assert info["position_error"] < 0.2 * start_error


def _feedforward_rms(env_id: str, steps: int = 250) -> float:
    """RMS tracking error (m) of the feed-forward controller on the episode of seed 11."""
    from planar3p_agents.controllers.tracking import TrackingController

    env = gym.make(env_id)
    ctrl = TrackingController.from_env(env)
    obs, info = env.reset(seed=11)
    for _ in range(steps):
        obs, _, terminated, truncated, info = env.step(ctrl(obs))
        if terminated or truncated:
            break
    return float(info["tracking_rms_error"])


# ------------------------------------------------------------------ trusted files
class _RunsCode:
    """Unpickling this writes a marker file: stands for any code a pickle can run."""

    def __init__(self, marker) -> None:
        self.marker = str(marker)

    def __reduce__(self):
        return (Path(self.marker).write_text, ("code ran",))


def _shipped_copy(tmp_path: Path) -> Path:
    copy = tmp_path / "pretrained"
    shutil.copytree(PRETRAINED_DIR, copy)
    return copy


def test_shipped_files_match_the_manifest() -> None:
    sums = (PRETRAINED_DIR / MANIFEST).read_text().splitlines()
    listed = {line.split("  ")[1] for line in sums}
    for name in SHIPPED:
        shipped = shipped_model(name)
        files = {shipped.relative(p) for p in shipped.files()}
        assert len(files) == 5 and files <= listed  # provenance, model, stats, config, args
        verified = verify_pretrained(name)
        assert verified == [shipped.model, shipped.stats]
        assert [p.name for p in verified] == [f"{shipped.env_id}.zip", "vecnormalize.pkl"]
    # every file of every model folder is listed: the page and the manifest only are not
    every = {p.relative_to(PRETRAINED_DIR).as_posix() for p in PRETRAINED_DIR.rglob("*")}
    assert {p for p in every if (PRETRAINED_DIR / p).is_file()} == listed | {"README.md", MANIFEST}
    for line in sums:  # sha256sum format, and the sums are those of the files
        digest, name = line.split("  ")
        assert file_sha256(PRETRAINED_DIR / name) == digest


@pytest.mark.parametrize("suffix", [".zip", "vecnormalize.pkl"])
def test_a_corrupted_shipped_file_is_refused(tmp_path, monkeypatch, suffix) -> None:
    name = SHIPPED[0]
    copy = _shipped_copy(tmp_path)
    shipped = shipped_model(name, copy)
    target = shipped.model if suffix == ".zip" else shipped.stats
    data = bytearray(target.read_bytes())
    data[len(data) // 2] ^= 0x01  # one flipped bit
    target.write_bytes(bytes(data))
    with pytest.raises(PolicyError, match=f"checksum mismatch for shipped file .*{suffix}"):
        verify_pretrained(name, copy)
    monkeypatch.setattr(policy_spec, "PRETRAINED_DIR", copy)
    with pytest.raises(PolicyError, match="checksum mismatch"):
        load_policy(f"pretrained:{name}", env=gym.make("Planar3P-v0"))


@pytest.mark.parametrize("text", ["{", '{"name": "x"}'])
def test_a_tampered_provenance_record_is_a_checksum_mismatch(tmp_path, monkeypatch, text) -> None:
    """An altered provenance.json (not JSON, or without its run) was reported as an "unknown
    pretrained model"; it is a shipped file that fails its checksum."""
    name = SHIPPED[0]
    copy = _shipped_copy(tmp_path)
    shipped_model(name, copy).provenance.write_text(text)
    monkeypatch.setattr(policy_spec, "PRETRAINED_DIR", copy)
    with pytest.raises(PolicyError, match=r"checksum mismatch for shipped file .*provenance\.json"):
        policy_spec.parse_policy_spec(f"pretrained:{name}")
    with pytest.raises(PolicyError, match="checksum mismatch"):
        load_policy(f"pretrained:{name}")


def test_a_shipped_file_replaced_by_code_is_never_unpickled(tmp_path, monkeypatch) -> None:
    name = SHIPPED[0]
    copy = _shipped_copy(tmp_path)
    marker = tmp_path / "ran.txt"
    shipped = shipped_model(name, copy)
    shipped.stats.write_bytes(pickle.dumps(_RunsCode(marker)))
    monkeypatch.setattr(policy_spec, "PRETRAINED_DIR", copy)
    with pytest.raises(PolicyError, match="checksum mismatch"):
        load_policy(f"pretrained:{name}")
    assert not marker.exists()
    # A file missing from the manifest is refused too.
    (copy / MANIFEST).write_text(
        "".join(
            line + "\n"
            for line in (copy / MANIFEST).read_text().splitlines()
            if not line.endswith(shipped.relative(shipped.model))
        )
    )
    with pytest.raises(PolicyError, match="not listed"):
        verify_pretrained(name, copy)


@pytest.mark.parametrize(
    ("model", "stats"),
    [
        ("run/model.zip", "run/vecnormalize.pkl"),  # scripts/train.py
        ("run/best_model.zip", "run/best_vecnormalize.pkl"),
        ("zoo/Planar3P-v0_1/Planar3P-v0.zip", "zoo/Planar3P-v0_1/Planar3P-v0/vecnormalize.pkl"),
        ("zoo/Planar3P-v0_1/best_model.zip", "zoo/Planar3P-v0_1/Planar3P-v0/vecnormalize.pkl"),
    ],
)
def test_statistics_beside_a_model_are_never_loaded_unnamed(tmp_path, model, stats) -> None:
    """A crafted statistics file beside a user's model would run code if unpickled: the model
    is refused (not silently evaluated without them) and the file is never opened."""
    model_path, stats_path = tmp_path / model, tmp_path / stats
    stats_path.parent.mkdir(parents=True, exist_ok=True)
    model_path.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(shipped_model(REACH_V0).model, model_path)
    marker = tmp_path / "ran.txt"
    stats_path.write_bytes(pickle.dumps(_RunsCode(marker)))
    env = gym.make("Planar3P-v0")
    with pytest.raises(PolicyError, match="none were named") as err:
        load_policy(str(model_path), env=env)
    assert f"{model_path}:stats={stats_path}" in str(err.value)  # says how to name them
    assert not marker.exists()
    policy = load_policy(f"{model_path}:stats=none", env=env)  # explicitly without
    assert policy.vecnormalize is None and not marker.exists()


def test_named_statistics_are_loaded(tmp_path) -> None:
    name = REACH_V0
    model = tmp_path / "model.zip"
    stats = tmp_path / "somewhere" / "stats.pkl"
    stats.parent.mkdir()
    shutil.copyfile(shipped_model(name).model, model)
    shutil.copyfile(shipped_model(name).stats, stats)
    env = gym.make("Planar3P-v0")
    shipped = load_policy(f"pretrained:{name}", env=env)
    for policy in (
        load_policy(f"{model}:stats={stats}", env=env),
        load_policy(str(model), env=env, vecnormalize=stats),
    ):
        assert policy.vecnormalize_path == stats
        np.testing.assert_array_equal(
            policy.vecnormalize.obs_rms.mean, shipped.vecnormalize.obs_rms.mean
        )
    assert policy_label(f"{model}:stats={stats}") == policy_label(str(model))
    with pytest.raises(PolicyError, match="statistics file not found"):
        load_policy(f"{model}:stats={tmp_path / 'nope.pkl'}")
    with pytest.raises(PolicyError, match="named twice"):
        load_policy(f"{model}:stats={stats}", vecnormalize=stats)
    with pytest.raises(PolicyError, match="model paths only"):
        load_policy(f"pretrained:{name}:stats={stats}")
    assert "code" in TRUSTED_FILES_NOTE and "trust" in TRUSTED_FILES_NOTE


def test_an_rl_zoo_model_is_labelled_by_its_run(tmp_path) -> None:
    run = tmp_path / "logs" / "ppo" / "Planar3P-v0_1"
    (run / "Planar3P-v0").mkdir(parents=True)
    assert policy_label(str(run / "Planar3P-v0.zip")) == "Planar3P-v0_1/Planar3P-v0"
    assert policy_label(str(tmp_path / "ppo_fast.zip")) == "ppo_fast"


def test_shipped_models_report_their_training_arguments(tmp_path):
    """A shipped model's environment arguments come from its provenance record (the
    benchmark plays a model with the observation arguments it was trained with); an
    unreadable record gives ``None``, never an error."""
    assert run_env_kwargs(shipped_model("ppo_assembly_change").model) == {"travel_shaping": 2.0}
    assert run_env_kwargs(shipped_model(REACH_V0).model) == {}
    copy = tmp_path / "pretrained"
    shutil.copytree(shipped_model(REACH_V0).folder, copy / "m")
    model = shipped_model("m", copy).model
    (copy / "m" / "provenance.json").write_text("{not json")
    assert run_env_kwargs(model) is None
    (copy / "m" / "provenance.json").write_text(json.dumps({"name": "m"}))  # no "run" entry
    assert run_env_kwargs(model) is None


# ---------------------------------------------- the id a model was trained on
def test_a_pretrained_model_is_refused_on_another_id() -> None:
    """``load_policy`` refuses a model trained on another id, naming both ids, before it
    loads anything (here the mode-change policy, whose observation would not even fit)."""
    with pytest.raises(PolicyError) as err:
        load_policy("pretrained:ppo_mode_change", env=gym.make("Planar3P-v0"))
    message = str(err.value)
    assert "trained on Planar3PModeChange-v0" in message and "environment is Planar3P-v0" in message
    assert "provenance.json" in message  # where the id was read


def test_the_goal_policy_plays_both_goal_ids() -> None:
    """The two goal ids register one environment class (they differ in the reward only): the
    policy trained on the dense one plays the sparse one (its benchmark suite ``goal``)."""
    policy = load_policy("pretrained:ppo_goal", env=gym.make("Planar3PGoal-v0"))
    assert policy.name == "pretrained:ppo_goal"


def _tiny_model(path: Path, env_id: str = "Planar3P-v0") -> Path:
    from stable_baselines3 import PPO

    path.parent.mkdir(parents=True, exist_ok=True)
    PPO("MlpPolicy", gym.make(env_id), n_steps=32, batch_size=32, seed=0).save(path)
    return path


def test_a_run_model_is_refused_on_another_id(tmp_path) -> None:
    """The id comes from the run's ``config.json`` (beside the model, or one level up for a
    checkpoint); a model whose run records none, or an unreadable one, is not refused for it."""
    model = _tiny_model(tmp_path / "run" / "model.zip")
    ckpt = _tiny_model(tmp_path / "run" / "checkpoints" / "rl_model_64_steps.zip")
    config = tmp_path / "run" / "config.json"
    config.write_text(json.dumps({"config": {"env_id": "Planar3PTrack-v0", "env_kwargs": {}}}))
    env = gym.make("Planar3P-v0")
    for path in (model, ckpt):
        with pytest.raises(PolicyError, match=r"trained on Planar3PTrack-v0 .*Planar3P-v0") as err:
            load_policy(f"{path}:stats=none", env=env)
        assert str(config) in str(err.value)
    config.write_text(json.dumps({"config": {"env_id": "Planar3P-v0"}}))
    assert load_policy(f"{model}:stats=none", env=env).env_kwargs is None
    for text in ("{not json", json.dumps({"config": {"seed": 1}})):
        config.write_text(text)
        load_policy(f"{model}:stats=none", env=env)


def test_planar3p_v1_models_play_on_v0(tmp_path) -> None:
    """``Planar3P-v1`` ran the machine ``Planar3P-v0`` runs now: its models play there, and
    nowhere else; the message says what the id became."""
    model = _tiny_model(tmp_path / "run" / "model.zip")
    (tmp_path / "run" / "config.json").write_text(json.dumps({"config": {"env_id": "Planar3P-v1"}}))
    load_policy(f"{model}:stats=none", env=gym.make("Planar3P-v0"))
    with pytest.raises(PolicyError, match=r"Planar3P-v1 \(now Planar3P-v0\)"):
        load_policy(f"{model}:stats=none", env=gym.make("Planar3PModeChange-v0"))


def test_an_rl_zoo_model_is_refused_on_another_id(tmp_path) -> None:
    """rl-zoo3's ``args.yml`` (an ``OrderedDict`` with an ``EnvironmentName`` in PyYAML's Python
    tags, read as plain data: nothing in it is constructed) records the id of its models."""
    from planar3p_agents.policies.sb3_models import training_record

    run = tmp_path / "logs" / "ppo" / "Planar3P-v0_1"
    model = _tiny_model(run / "Planar3P-v0.zip")
    best = _tiny_model(run / "best_model.zip")
    (run / "Planar3P-v0").mkdir()
    (run / "Planar3P-v0" / "args.yml").write_text(
        "!!python/object/apply:collections.OrderedDict\n"
        "- - - algo\n    - ppo\n"
        "  - - env\n    - !!python/object/new:huggingface_sb3.naming_schemes.EnvironmentName\n"
        "      args:\n      - Planar3PModeChange-v0\n      state:\n        _gym_id: x\n"
        "  - - env_kwargs\n    - travel_shaping: 2.0\n"
        "  - - seed\n    - 7\n"
    )
    record = training_record(model)
    assert (record.env_id, record.env_kwargs, record.seed) == (
        "Planar3PModeChange-v0",
        {"travel_shaping": 2.0},
        7,
    )
    for path in (model, best):
        with pytest.raises(PolicyError, match="trained on Planar3PModeChange-v0"):
            load_policy(f"{path}:stats=none", env=gym.make("Planar3P-v0"))
