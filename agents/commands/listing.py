"""List the registered ids, the built-in baselines and the shipped pretrained models.

WHAT is ids (each registered id, its episode limit and what it is), baselines (each baseline and
the ids it plays), pretrained (each shipped model, its algorithm, the id it was trained on and
its policy) or all (the default). --json prints the same as JSON.

examples:
  planar3p list
  planar3p list baselines
  planar3p list pretrained --json

Library: planar3p_gym.envs.registry.registrations,
planar3p_agents.controllers.registry.BASELINES, planar3p_agents.zoo.layout.shipped_model.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from planar3p_agents.commands.parser import CliParser

#: What ``planar3p list`` can list.
SECTIONS = ("ids", "baselines", "pretrained")


def add_arguments(p: CliParser) -> None:
    p.add_argument(
        "what", nargs="?", default="all", choices=(*SECTIONS, "all"), help="what to list"
    )
    p.add_argument("--json", action="store_true", help="print JSON")


def check(args: argparse.Namespace) -> None:
    """Nothing beyond the parser's choices."""


def catalogue(sections: tuple[str, ...]) -> dict[str, list[dict[str, Any]]]:
    """The rows of each of ``sections`` (:data:`SECTIONS`), as plain data."""
    out: dict[str, list[dict[str, Any]]] = {}
    if "ids" in sections:
        from planar3p_gym.envs.registry import registrations

        out["ids"] = [
            {"id": r.id, "max_episode_steps": r.max_episode_steps, "summary": r.summary}
            for r in registrations()
        ]
    if "baselines" in sections:
        from planar3p_agents.controllers.registry import BASELINES

        out["baselines"] = [
            {"name": b.name, "description": b.description, "ids": list(b.ids)}
            for b in BASELINES.values()
        ]
    if "pretrained" in sections:
        from planar3p_agents.zoo.layout import read_provenance, shipped_model, shipped_names

        rows = []
        for name in shipped_names():
            model = shipped_model(name)
            config = read_provenance(model.provenance)["run"]["config"]
            rows.append(
                {
                    "name": f"pretrained:{name}",
                    "algo": model.algo,
                    "env_id": model.env_id,
                    "policy": config.get("policy", ""),
                }
            )
        out["pretrained"] = rows
    return out


def _text(section: str, rows: list[dict[str, Any]]) -> str:
    """One section as aligned lines."""
    if section == "ids":
        cells = [(r["id"], f"{r['max_episode_steps']} steps", r["summary"]) for r in rows]
    elif section == "baselines":
        cells = [(r["name"], r["description"], ", ".join(r["ids"])) for r in rows]
    else:
        cells = [(r["name"], r["algo"], r["env_id"], r["policy"]) for r in rows]
    if not cells:
        return f"{section}:\n  (none)"
    widths = [max(len(c[k]) for c in cells) for k in range(len(cells[0]) - 1)]
    lines = [
        "  " + "  ".join(c[k].ljust(widths[k]) for k in range(len(widths))) + "  " + c[-1]
        for c in cells
    ]
    return f"{section}:\n" + "\n".join(lines)


def run(args: argparse.Namespace) -> int:
    sections = SECTIONS if args.what == "all" else (args.what,)
    data = catalogue(sections)
    if args.json:
        print(json.dumps(data, indent=2))
    else:
        print("\n\n".join(_text(s, data[s]) for s in sections))
    return 0
