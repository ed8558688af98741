"""One page per registered environment id, generated from a class docstring.

In the spirit of Gymnasium's page generator (its ``gen_mds.py``): the ids are read from the
Gymnasium registry after ``import planar3p_gym`` (every id starting with ``Planar3P``).  An
id's page is the docstring of its entry point's class, or of its task's class for an id of the
generic environment that names its task (``kwargs["task"]``, as
:func:`planar3p_gym.envs.registry.register_task` registers it): the sections Description,
Action Space, Observation Space, Rewards, Starting State, Episode End, Arguments, Version
History.  It is preceded by the facts read from a made environment (spaces, time limit,
registered arguments) and the media of ``scripts/docs_media.py``, and followed by the
observation layout index by index and the baselines measured by the benchmark
(``docs/benchmark``).

Writes ``docs/envs/<id>.md`` and the table of all ids, ``docs/_generated/env_table.md``.
"""

from __future__ import annotations

import importlib
import inspect
import json
import math
import re
import warnings
from pathlib import Path
from typing import Any

import p3docs as P
from results_data import baseline_summaries, format_success, study_page_name

#: Where the pages are written.
OUT = P.DOCS / "envs"
#: Media written by ``scripts/docs_media.py``.
MEDIA = P.STATIC / "envs"
#: Hand-written details of a task, by task name (``reach``, ``goal``, ...), shown on the page of
#: every id of that task after its docstring.
TASK_NOTES = P.NOTES / "tasks"

#: The goal entries of the goal-conditioned ids (``achieved_goal`` and ``desired_goal``).
GOAL_FIELDS = (
    ("x, y", 2, "gripper point G (m)"),
    ("cos theta, sin theta", 2, "platform orientation"),
    ("v", 1, "speed of the fastest slider (m/s); desired: 0, at rest"),
)

#: What success adds to the reach test, by task name.
SUCCESS_EXTRA = {
    "reach": "",
    "goal": " (the goal pose; at rest is part of the goal)",
    "mode_change": ", every leg in the target working mode",
    "assembly_change": ", in the target's assembly mode",
}


def _warn(msg: str) -> None:
    warnings.warn(msg, stacklevel=2)


def entry_class(env_id: str) -> type:
    """The class of ``gymnasium.spec(env_id).entry_point``."""
    import gymnasium as gym

    ep = gym.spec(env_id).entry_point
    if callable(ep):
        return ep  # type: ignore[return-value]
    module, _, attr = ep.partition(":")
    return getattr(importlib.import_module(module), attr)


def page_class(env_id: str) -> type:
    """The class whose docstring is the page of ``env_id``: the task class named by the id's
    registered ``task`` (``"module:Class"``), else the entry point's class."""
    import gymnasium as gym

    task = gym.spec(env_id).kwargs.get("task")
    if isinstance(task, str):
        module, _, attr = task.partition(":")
        return getattr(importlib.import_module(module), attr)
    return entry_class(env_id)


def docstring_sections(cls: type) -> tuple[str, str]:
    """``(summary, body)`` of a class docstring: its first paragraph and the rest, the rest
    with its RST roles as MyST roles resolved in the class's context."""
    doc = inspect.cleandoc(cls.__doc__ or "")
    summary, _, body = doc.partition("\n\n")
    summary = " ".join(summary.split())
    body = P.myst_roles(body, cls.__module__, cls.__qualname__)
    summary = P.myst_roles(summary, cls.__module__, cls.__qualname__)
    return summary, body


def _obs_module() -> Any:
    return importlib.import_module(P.find_module("observation"))


def _space_text(space: Any) -> str:
    import gymnasium as gym

    if isinstance(space, gym.spaces.Dict):
        inner = ", ".join(f"{k} {getattr(v, 'shape', v)}" for k, v in space.spaces.items())
        return f"Dict({inner})"
    if isinstance(space, gym.spaces.Box):
        if (
            space.is_bounded()
            and space.low.size
            and (space.low == space.low.flat[0]).all()
            and (space.high == space.high.flat[0]).all()
        ):
            low, high = space.low.flat[0], space.high.flat[0]
            return f"Box({low:g}, {high:g}, {space.shape}, {space.dtype})"
        return f"Box({space.shape}, {space.dtype})"
    return str(space)


def _blocks_table(fields: Any, start: int = 0) -> tuple[list[list[str]], int]:
    rows, i = [], start
    for name, size, meaning in fields:
        idx = str(i) if size == 1 else f"{i}-{i + size - 1}"
        rows.append([idx, f"`{name}`", meaning])
        i += size
    return rows, i


def observation_layout(env: Any) -> str:
    """The observation index by index, as Markdown."""
    import gymnasium as gym

    obs_mod = _obs_module()
    base = obs_mod.OBS_FIELDS
    space = env.observation_space
    task = env.unwrapped.task
    header = ["index", "name", "meaning"]
    if isinstance(space, gym.spaces.Dict):
        module = importlib.import_module(type(env.unwrapped).__module__)
        robot = getattr(module, "ROBOT_FIELDS", None)
        out = []
        if robot is not None:
            sizes = {n: (s, m) for n, s, m in base}
            rows, n = _blocks_table([(r, *sizes[r]) for r in robot])
            if n != space["observation"].shape[0]:
                _warn(
                    f"{env.spec.id}: the observation layout has {n} entries, the space "
                    f"{space['observation'].shape[0]}"
                )
            out.append("`observation`:\n\n" + P.md_table(header, rows))
        rows, n = _blocks_table(GOAL_FIELDS)
        out.append("`achieved_goal` and `desired_goal`:\n\n" + P.md_table(header, rows))
        return "\n".join(out)
    extra = task.observation_fields  # (their one definition: the task's)
    rows, n = _blocks_table(base)
    more, n = _blocks_table(extra, n)
    if n != space.shape[0]:
        _warn(f"{env.spec.id}: the documented layout has {n} entries, the space {space.shape[0]}")
    text = P.md_table(header, rows + more)
    if getattr(task, "name", "") == "reach":
        tg, _ = _blocks_table(obs_mod.TRAVEL_GOAL_FIELDS, n)
        text += (
            "\nWith `travel_goal=True` the goal in joint space follows "
            f"({n + obs_mod.TRAVEL_GOAL_SIZE} entries):\n\n" + P.md_table(header, tg)
        )
    scale = getattr(obs_mod, "FINE_ERROR_SCALE", None)
    if scale:
        text += f"\n`FINE_ERROR_SCALE` = {scale * 100:g} cm.\n"
    return text


def success_text(env: Any) -> str:
    """The success test of ``env``, with the tolerances of its task configuration."""
    task = env.unwrapped.task
    name = getattr(task, "name", "")
    if name == "track":
        return "none (no success test: tracking error metrics)"
    cfg = env.unwrapped.task_config
    return (
        f"within {cfg.position_tolerance * 1000:g} mm and "
        f"{math.degrees(cfg.orientation_tolerance):g} deg, sliders slower than "
        f"{cfg.rest_speed:g} m/s{SUCCESS_EXTRA.get(name, '')}"
    )


def _episode_length(spec: Any, env: Any) -> str:
    steps = spec.max_episode_steps
    if steps is None:
        return "no limit"
    rate = env.metadata.get("render_fps") or 50
    return f"{steps} ({steps / rate:g} s)"


def media(env_id: str) -> tuple[Path, Path, dict[str, Any]]:
    """The frame, the animation and their description written by ``scripts/docs_media.py``."""
    png, gif, meta = (MEDIA / f"{env_id}{ext}" for ext in (".png", ".gif", ".json"))
    info = json.loads(meta.read_text()) if meta.exists() else {}
    return png, gif, info


def _baseline_section(env_id: str) -> tuple[str, str]:
    """(Markdown section of the baselines of ``env_id``, one-line summary for the table)."""
    rows = baseline_summaries(env_id)
    if not rows:
        return "", "–"
    tracking = any(r["tracking_rms_mm"] is not None for r in rows)
    header = ["suite", "policy", "success % [95% CI]", "median time to success s"]
    if tracking:
        header = ["suite", "policy", "tracking RMS error mm (median / worst)"]
    table, best = [], {}
    for r in rows:
        if tracking:
            table.append(
                [
                    r["suite"],
                    f"`{r['policy']}`",
                    f"{r['tracking_rms_mm']:.2f} / {r['tracking_rms_worst_mm']:.2f}",
                ]
            )
            key = r["tracking_rms_mm"]
            if r["suite"] not in best or key < best[r["suite"]][0]:
                best[r["suite"]] = (key, f"{r['suite']}: {r['policy']} {key:.2f} mm RMS")
        else:
            t = r["time_to_success"]
            table.append(
                [
                    r["suite"],
                    f"`{r['policy']}`",
                    format_success(r),
                    "–" if t is None else f"{t:.2f}",
                ]
            )
            key = (r["success_rate"] or 0.0, -(t or math.inf))
            if r["suite"] not in best or key > best[r["suite"]][0]:
                best[r["suite"]] = (key, f"{r['suite']}: {r['policy']} {format_success(r)} %")
    studies = sorted({r["study"] for r in rows})
    links = ", ".join(f"[{s}](../results/{study_page_name(s)}.md)" for s in studies)
    section = (
        "## Baselines\n\n"
        "Built-in (not learned) policies on the benchmark's fixed suites (seed 0), from the "
        f"benchmark data of {links}; learned policies are on the results pages.\n\n"
        + P.md_table(header, table)
    )
    summary = "; ".join(v[1] for v in best.values())
    return section, summary


def env_page(env_id: str) -> tuple[str, dict[str, str]]:
    """The Markdown page of ``env_id`` and its row of the table of ids."""
    import gymnasium as gym

    spec = gym.spec(env_id)
    cls = entry_class(env_id)
    summary, body = docstring_sections(page_class(env_id))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Gymnasium's "out of date" note on older versions
        env = gym.make(env_id)
    try:
        act = _space_text(env.action_space)
        obs = _space_text(env.observation_space)
        length = _episode_length(spec, env)
        layout = observation_layout(env)
        success = success_text(env)
        task = getattr(env.unwrapped.task, "name", "")
    finally:
        env.close()
    png, gif, info = media(env_id)
    lines = [f"# {env_id}", "", summary, ""]
    if png.exists() and gif.exists():
        caption = info.get("caption", "")
        lines += [
            "```{image} " + f"../_static/envs/{png.name}",
            f":alt: a rendered frame of {env_id}",
            ":width: 45%",
            "```",
            "```{image} " + f"../_static/envs/{gif.name}",
            f":alt: an episode of {env_id}",
            ":width: 45%",
            "```",
            "",
            f"*Left: the first frame of an episode. Right: {caption}*" if caption else "",
            "",
        ]
    else:
        _warn(f"{env_id}: no media in {MEDIA} (run: python scripts/docs_media.py)")
    kwargs = ", ".join(f"`{k}={v!r}`" for k, v in spec.kwargs.items()) or "none"
    vec = getattr(spec, "vector_entry_point", None)
    facts = [
        ["Make", f'`gymnasium.make("{env_id}")`'],
        ["Class", f"{{class}}`{P.qualified_name(cls)}`"],
        ["Task", f"`{task}`"],
        ["Action space", f"`{act}`"],
        ["Observation space", f"`{obs}`"],
        ["Episode length (steps)", length],
        ["Success test", success],
        ["Registered arguments", kwargs],
        [
            "Vector env",
            "native (`gymnasium.make_vec(id, num_envs=n)`)"
            if vec
            else "`SyncVectorEnv` (no native vector env)",
        ],
    ]
    lines += [P.md_table(["", ""], facts), body.strip(), ""]
    note = TASK_NOTES / f"{task}.md"
    if note.exists():
        lines += ["## More about this task", "", note.read_text().strip(), ""]
    lines += ["## Observation layout", "", layout, ""]
    section, best = _baseline_section(env_id)
    if section:
        lines += [section, ""]
    row = {
        "id": f"[`{env_id}`]({env_id}.md)",
        "task": task,
        "action": f"`{act}`",
        "observation": f"`{obs}`",
        "length": length,
        "success": success,
        "baseline": best,
    }
    return "\n".join(lines).rstrip() + "\n", row


def generate() -> list[Path]:
    """Write every page and the table of ids; returns the paths written."""
    written = []
    rows = []
    ids = P.registered_ids()
    for env_id in ids:
        text, row = env_page(env_id)
        rows.append(row)
        path = OUT / f"{env_id}.md"
        if P.write_if_changed(path, text):
            written.append(path)
    for stale in OUT.glob("*.md"):
        if stale.stem not in ids:
            stale.unlink()
    header = [
        "id",
        "task",
        "action",
        "observation",
        "episode steps",
        "success test",
        "strongest built-in baseline (fixed suites, seed 0)",
    ]
    table = P.md_table(
        header,
        [
            [r[k] for k in ("id", "task", "action", "observation", "length", "success", "baseline")]
            for r in rows
        ],
    )
    # links in an included fragment are relative to the including page (docs/)
    table = re.sub(r"\]\((Planar3P[^)]*\.md)\)", r"](envs/\1)", table)
    if P.write_if_changed(P.GENERATED / "env_table.md", table):
        written.append(P.GENERATED / "env_table.md")
    toctree = "```{toctree}\n:maxdepth: 1\n\n" + "".join(f"envs/{i}\n" for i in ids) + "```\n"
    if P.write_if_changed(P.GENERATED / "env_toctree.md", toctree):
        written.append(P.GENERATED / "env_toctree.md")
    return written


if __name__ == "__main__":
    for p in generate():
        print(p)
