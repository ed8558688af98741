"""A model card per shipped policy, generated from its provenance record.

Reads every ``<name>/provenance.json`` beside ``SHA256SUMS`` in the agents package's ``pretrained``
folder (found by searching the package, wherever it moves) and writes ``docs/models/<name>.md``:
task (environment id and arguments), algorithm and hyperparameters, the training command,
seeds, the run's own final evaluation, the benchmark figures that name the model's run (with
the strongest built-in baselines of the same study beside them), figures, and the SHA-256 sums
of its files.  Also ``docs/_generated/models_table.md``, one line per model.
"""

from __future__ import annotations

import importlib
import json
import re
from pathlib import Path
from typing import Any

import p3docs as P
from results_data import format_success, is_builtin, row_of, studies, study_page_name

from planar3p_gym.envs.core import OBSERVATION_ARGUMENTS

OUT = P.DOCS / "models"
FIGURES = P.DOCS / "figures"


def pretrained_dir() -> Path:
    """The folder of the shipped policies (the one holding ``SHA256SUMS``)."""
    pkg = importlib.import_module(P.agents_package())
    hits = sorted(Path(next(iter(pkg.__path__))).rglob("SHA256SUMS"))
    if len(hits) != 1:
        raise LookupError(f"expected one SHA256SUMS in the agents package, found {hits}")
    return hits[0].parent


def checksums(folder: Path) -> dict[str, str]:
    """File (relative to ``folder``) -> SHA-256, from ``SHA256SUMS``."""
    out = {}
    for line in (folder / "SHA256SUMS").read_text().splitlines():
        if line.strip():
            digest, name = line.split(maxsplit=1)
            out[name.lstrip("*")] = digest
    return out


def _clean_command(command: str) -> str:
    """The recorded command with machine-specific absolute run paths made relative."""
    command = re.sub(r"\S*/(runs/)", r"\1", command)
    if command.startswith("scripts/"):  # a script run as a file (planar3p is a command)
        command = "python " + command
    return command


def _wrap_command(command: str, width: int = 88) -> str:
    words = command.split(" ")
    lines, cur = [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width and w.startswith("--"):
            lines.append(cur + " \\")
            cur = "    " + w
        else:
            cur = f"{cur} {w}" if cur else w
    lines.append(cur)
    return "\n".join(lines)


def benchmark_rows(record: dict[str, Any]) -> list[tuple[dict[str, Any], list[dict[str, Any]]]]:
    """For each study that played this model: (its rows, the built-in policies' rows)."""
    name = record["name"]
    run, model = record.get("source_run", ""), record.get("source_model", "")
    found = []
    for study in studies():
        specs = study["summary"]["settings"].get("policies", {})
        labels = [
            label
            for label, spec in specs.items()
            if spec == f"pretrained:{name}" or (run and f"{run}/{model}" in spec)
        ]
        if not labels:
            continue
        mine = [row_of(study, s) for s in study["summary"]["summaries"] if s["policy"] in labels]
        base = [
            row_of(study, s)
            for s in study["summary"]["summaries"]
            if is_builtin(specs.get(s["policy"], s["policy"]))
        ]
        found.append((study, mine, base))
    return found


def _score(r: dict[str, Any]) -> str:
    if r["tracking_rms_mm"] is not None:
        return f"{r['tracking_rms_mm']:.2f} mm median RMS (worst {r['tracking_rms_worst_mm']:.2f})"
    t = r["time_to_success"]
    return f"{format_success(r)} %" + ("" if t is None else f", {t:.2f} s")


def _strongest(rows: list[dict[str, Any]], suite: str) -> list[dict[str, Any]]:
    """The built-in policies worth naming beside a learned figure on ``suite``: the best one
    and the plain analytic controller (when it is not the best)."""
    cand = [
        r for r in rows if r["suite"] == suite and r["policy"] != "zero" and r["policy"] != "random"
    ]
    if not cand:
        return []
    if cand[0]["tracking_rms_mm"] is not None:
        best = min(cand, key=lambda r: r["tracking_rms_mm"])
    else:
        best = max(cand, key=lambda r: (r["success_rate"] or 0, -(r["time_to_success"] or 1e9)))
    out = [best]
    plain = [r for r in cand if r["policy"] == "analytic-simultaneous" and r is not best]
    return out + plain


def _learning_curves(study: str) -> list[str]:
    stems = sorted(p.stem for p in FIGURES.glob("learning_curves_*.png"))
    key = study.replace("-", "_")
    return [
        s
        for s in stems
        if key == s[len("learning_curves_") :] or key.startswith(s[len("learning_curves_") :] + "_")
    ]


def model_card(record: dict[str, Any], sums: dict[str, str]) -> tuple[str, list[str]]:
    name = record["name"]
    run = record.get("run", {})
    cfg = run.get("config", {})
    env_id = cfg.get("env_id", "?")
    env_kwargs = cfg.get("env_kwargs") or {}
    algo_class = cfg.get("algo", "ppo").upper()  # SB3's class names: PPO, SAC, TD3, TQC, DQN
    kick = run.get("kickstart")
    metrics = (record.get("metrics") or {}).get("final_evaluation")
    lines = [f"# `pretrained:{name}`", ""]
    if record.get("note"):
        lines += [P.md_cell(record["note"]), ""]
    env_link = (
        f"[`{env_id}`](../envs/{env_id}.md)"
        if env_id in P.registered_ids()
        else f"`{env_id}` (no longer registered)"
    )
    facts = [
        ["Task", f"{env_link}" + (f" with `{json.dumps(env_kwargs)}`" if env_kwargs else "")],
        [
            "Algorithm",
            f"{cfg.get('algo', '?').upper()}, policy `{cfg.get('policy', '?')}`, "
            f"{cfg.get('n_envs', '?')} envs"
            + (
                f"; kick-started from `{kick['teacher']}` ({kick['steps']:,} "
                "teacher-labelled steps)"
                if kick
                else "; learned from scratch"
            ),
        ],
        ["Training seed", str(cfg.get("seed", "?"))],
        [
            "Source",
            f"run `{record.get('source_run', '?')}`, file `{record.get('source_model', '?')}`",
        ],
    ]
    if metrics:
        facts.append(
            [
                "Run's own final evaluation",
                f"success {100 * metrics['success_rate']:.0f} % over {metrics['episodes']} "
                "env-sampled episodes (training distribution, not the fixed suites)",
            ]
        )
    steps = (record.get("metrics") or {}).get("timesteps")
    if steps:
        facts.append(["Training steps", f"{steps:,}"])
    versions = record.get("versions") or {}
    if versions:
        facts.append(
            [
                "Trained with",
                ", ".join(
                    f"{k} {v}"
                    for k, v in versions.items()
                    if k
                    in ("Python", "Stable-Baselines3", "PyTorch", "Gymnasium", "pymunk", "rl_zoo3")
                ),
            ]
        )
    lines += [P.md_table(["", ""], facts), ""]

    kwargs = "".join(f", {k}={v!r}" for k, v in env_kwargs.items() if k in OBSERVATION_ARGUMENTS)
    registered = env_id in P.registered_ids()
    lines += [
        "## Use it",
        "",
        "The loader checks the files' SHA-256 sums and loads the observation statistics "
        f"(`VecNormalize`) with the model: a plain `{algo_class}.load` of the `.zip` without "
        "them plays "
        "badly and silently.",
        "",
        "```python",
        *([] if registered else [f"# not run: {env_id} is not registered any more"]),
        "import gymnasium as gym",
        "import planar3p_gym",
        f"from {P.agents_package()}.policies.factory import load_policy",
        "",
        f'env = gym.make("{env_id}"{kwargs})',
        f'policy = load_policy("pretrained:{name}", env=env)',
        "obs, info = env.reset(seed=0)",
        "action, _ = policy.predict(obs, deterministic=True)",
        "```",
        "",
        f"From the command line: `python scripts/benchmark.py --policies pretrained:{name}` "
        "(see [the benchmark](../benchmark.md)).",
        "",
    ]
    cmd = run.get("command")
    if cmd:
        lines += [
            "## Training command",
            "",
            "As recorded in the provenance (`scripts/train.py` runs torch on one thread, "
            "`--threads 1`, by default); it trains for minutes to hours (the documentation's "
            "tests run it for 64 steps):",
            "",
            "```bash",
            "# not run: trains for minutes to hours",
            _wrap_command(_clean_command(cmd)),
            "```",
            "",
        ]
    algo_kwargs = cfg.get("algo_kwargs") or {}
    if algo_kwargs:
        hp = [
            [f"`{k}`", f"`{json.dumps(v) if not isinstance(v, str) else v}`"]
            for k, v in algo_kwargs.items()
        ]
        lines += ["## Hyperparameters", "", P.md_table(["name", "value"], hp), ""]

    results = benchmark_rows(record)
    figures: list[str] = []
    summary = ""
    if results:
        lines += [
            "## On the benchmark's fixed suites",
            "",
            "Every figure with the strongest built-in policies of the same run (same "
            "episodes); success % with the 95 % Wilson interval, median time to "
            "success.",
            "",
        ]
        for study, mine, base in results:
            rows = []
            for r in mine:
                rows.append([r["suite"], f"**this model** (`{r['policy']}`)", _score(r)])
                for b in _strongest(base, r["suite"]):
                    rows.append([r["suite"], f"`{b['policy']}`", _score(b)])
            page = study_page_name(study["name"])
            lines += [
                f"Study [{study['name']}](../results/{page}.md):",
                "",
                P.md_table(["suite", "policy", "score"], rows),
                "",
            ]
            if not summary and mine:
                summary = "; ".join(f"{r['suite']} {_score(r)}" for r in mine)
            folder = study["folder"]
            for fig in ("success_rate.png",):
                if (folder / fig).exists():
                    rel = folder.relative_to(P.DOCS).as_posix()
                    figures.append(f"../{rel}/{fig}")
            figures += [f"../figures/{s}.png" for s in _learning_curves(study["name"])]
    if figures:
        lines += ["## Figures", ""]
        for fig in dict.fromkeys(figures):
            lines += [f"![{Path(fig).stem}]({fig})", ""]

    # The model's folder (``<name>/``: provenance and the rl-zoo3 layout, stored once).
    files = sorted(k for k in sums if k.startswith(name + "/"))
    rows = [[f"`{f}`", f"`{sums[f]}`"] for f in files]
    lines += [
        "## Files and checksums",
        "",
        "From `SHA256SUMS` in the shipped folder (`sha256sum -c SHA256SUMS` checks them; "
        "`pretrained:<name>` checks them before loading, rl-zoo3 does not: run "
        "`python scripts/ship_policy.py --verify <name>` first). Model and statistics files "
        "are unpickled when loaded: load only files you trust.",
        "",
        P.md_table(["file", "SHA-256"], rows),
    ]
    row = [
        f"[`pretrained:{name}`](models/{name}.md)",
        env_id,
        "kick-start + PPO" if kick else cfg.get("algo", "?").upper(),
        str(cfg.get("seed", "?")),
        summary or "–",
    ]
    return "\n".join(lines).rstrip() + "\n", row


def generate() -> list[Path]:
    folder = pretrained_dir()
    sums = checksums(folder)
    written, rows, names = [], [], []
    for path in sorted(folder.glob("*/provenance.json")):
        record = json.loads(path.read_text())
        record.setdefault("name", path.parent.name)
        text, row = model_card(record, sums)
        rows.append(row)
        names.append(record["name"])
        if P.write_if_changed(OUT / f"{record['name']}.md", text):
            written.append(OUT / f"{record['name']}.md")
    for stale in OUT.glob("*.md"):
        if stale.stem not in names:
            stale.unlink()
    table = P.md_table(["model", "id", "algorithm", "seed", "on the fixed suites"], rows)
    if P.write_if_changed(P.GENERATED / "models_table.md", table):
        written.append(P.GENERATED / "models_table.md")
    return written


if __name__ == "__main__":
    for p in generate():
        print(p)
