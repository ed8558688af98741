"""``planar3p list``: every registered id, every baseline with its ids and every shipped model,
as text and as JSON."""

from __future__ import annotations

import json

from planar3p_agents import cli
from planar3p_agents.commands.listing import catalogue
from planar3p_agents.controllers.registry import BASELINES
from planar3p_agents.zoo.layout import shipped_model, shipped_names
from planar3p_gym.envs.registry import registrations


def test_the_catalogue_lists_every_id_baseline_and_shipped_model() -> None:
    data = catalogue(("ids", "baselines", "pretrained"))
    assert [r["id"] for r in data["ids"]] == [r.id for r in registrations()]
    assert {r["name"]: r["ids"] for r in data["baselines"]} == {
        n: list(b.ids) for n, b in BASELINES.items()
    }
    names = shipped_names()
    assert names and [r["name"] for r in data["pretrained"]] == [f"pretrained:{n}" for n in names]
    for row, name in zip(data["pretrained"], names, strict=True):
        assert row["env_id"] == shipped_model(name).env_id


def test_json_and_text_show_the_same_rows(capsys) -> None:
    assert cli.main(["list", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert cli.main(["list"]) == 0
    text = capsys.readouterr().out
    for section, rows in data.items():
        assert f"{section}:" in text
        for row in rows:
            assert (row.get("id") or row["name"]) in text
    assert cli.main(["list", "pretrained", "--json"]) == 0
    assert list(json.loads(capsys.readouterr().out)) == ["pretrained"]
