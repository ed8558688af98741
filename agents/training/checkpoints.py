"""Where a ``scripts/train.py`` run keeps its checkpoints: SB3's ``CheckpointCallback`` with its
default prefix writes ``<run>/checkpoints/rl_model_<steps>_steps.zip`` and, beside it, the
``VecNormalize`` statistics and (off-policy) the replay buffer of the same step count.  The
trainer (resume), the shipping tool and the learning curves read that layout from here.

Only the newest checkpoint keeps its replay buffer (:func:`prune_replay_buffers`, called after
each save): a resume reads the newest checkpoint alone, and a buffer of a million transitions
takes about 300 MB, so one per checkpoint filled tens of GB in a five-seed study."""

from __future__ import annotations

import re
from pathlib import Path

__all__ = [
    "CHECKPOINT_DIR",
    "KINDS",
    "checkpoint_path",
    "prune_replay_buffers",
    "run_checkpoints",
]

#: The checkpoints' folder in a run directory (``CheckpointCallback``'s ``save_path``).
CHECKPOINT_DIR = "checkpoints"
#: What a checkpoint of ``n`` steps consists of: kind -> file name.
KINDS = {
    "model": "rl_model_{n}_steps.zip",
    "vecnormalize": "rl_model_vecnormalize_{n}_steps.pkl",
    "replay_buffer": "rl_model_replay_buffer_{n}_steps.pkl",
}


def checkpoint_path(steps: int, kind: str = "model") -> str:
    """The path, relative to a run directory, of the ``kind`` file (a key of :data:`KINDS`)
    of the checkpoint after ``steps`` environment steps."""
    return f"{CHECKPOINT_DIR}/{KINDS[kind].format(n=int(steps))}"


def run_checkpoints(run_dir: str | Path, kind: str = "model") -> dict[int, Path]:
    """The ``kind`` files (a key of :data:`KINDS`; default the models) of a run's
    checkpoints by step count (empty if it has none)."""
    head, tail = KINDS[kind].split("{n}")
    pattern = re.compile(re.escape(head) + r"(\d+)" + re.escape(tail))
    out = {}
    for path in (Path(run_dir) / CHECKPOINT_DIR).glob(f"{head}*{tail}"):
        m = pattern.fullmatch(path.name)
        if m:
            out[int(m.group(1))] = path
    return out


def prune_replay_buffers(run_dir: str | Path) -> list[Path]:
    """Delete every replay buffer of a run's checkpoints but the one of the most steps (what
    a resume loads, :func:`planar3p_agents.training.run.latest_checkpoint`); returns the
    deleted files.  Models and statistics are kept."""
    found = run_checkpoints(run_dir, "replay_buffer")
    stale = [found[n] for n in sorted(found)[:-1]]
    for path in stale:
        path.unlink()
    return stale
