"""The study's map of the draws: what each panel's legend counts, what is drawn where, and when there is no map."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import yaml
from conftest import ROOT
from matplotlib.patches import Circle

import harmony_cli.study.draw_map as draw_map_module
from harmony_cli.scenario import load_scenario, scenario_yaml
from harmony_cli.study.draw_map import draw_map
from harmony_cli.study.report import write_report
from harmony_cli.study.table import TABLE

SCENE = {
    "robot": {"base_pose": [0.0, 0.0, 0.0]},
    "world": {
        "tables": [{"name": "pick", "position": [2.0, 2.5], "yaw_deg": 30.0, "top": [1.5, 0.8]}],
        "box": {"size": [0.3, 0.3, 0.3], "position": [2.0, 2.3, 1.2], "goal": [5.0, 0.0, 1.2]},
        "obstacles": [{"name": "post", "shape": "cylinder", "position": [3.5, 1.5, 1.0], "size": [1.2, 1.2, 2.0]}],
    },
}
OUTCOMES = {  # grid point -> the outcome of samples 0, 1, ...
    "on": ["success", "success", "dropped", "success", "collision", "run failed: impossible"],
    "off": ["success", "dropped", "dropped", "interrupted", "success", "run failed: impossible"],
}


def _table(rng: np.random.Generator) -> pd.DataFrame:
    """Six draws at two grid points, with a start, a box and a cylinder drawn (and a mass, not a position)."""
    n = len(OUTCOMES["on"])
    draws = {
        "vary.robot.base_pose.0": rng.uniform(-0.5, 0.5, n),
        "vary.robot.base_pose.1": rng.uniform(-0.5, 0.5, n),
        "vary.robot.base_pose.2": rng.uniform(-45, 45, n),
        "vary.world.box.position.0": rng.uniform(1.8, 2.2, n),
        "vary.world.box.position.1": np.full(n, 2.3),
        "vary.world.box.position.2": np.full(n, 1.2),
        "vary.world.obstacles.post.position.0": rng.uniform(3.0, 4.0, n),
        "vary.world.obstacles.post.position.1": rng.uniform(0.5, 2.0, n),
        "vary.world.obstacles.post.position.2": np.full(n, 1.0),
        "vary.world.box.mass": rng.uniform(0.5, 1.5, n),
    }
    frames = [
        pd.DataFrame({"sample": range(n), "point": point, "outcome": outcomes} | draws)
        for point, outcomes in OUTCOMES.items()
    ]
    table = pd.concat(frames, ignore_index=True)
    return table.assign(success=table["outcome"].map({"success": True, "interrupted": None}).fillna(False))


def _panels(monkeypatch) -> dict[str, dict]:
    """Captures what each panel of the next map has, by its title, before the figure is saved and closed."""
    panels: dict[str, dict] = {}
    save = draw_map_module.save

    def keep(fig, path: Path) -> None:
        for ax in fig.axes:
            legend = ax.get_legend()
            counts = [re.fullmatch(r"(.*) \((\d+)\)", t.get_text()) for t in legend.get_texts()] if legend else []
            circles = [p for p in ax.patches if isinstance(p, Circle)]
            panels[ax.get_title()] = {
                "counts": {m[1]: int(m[2]) for m in counts if m},
                "outlines": [p.get_radius() for p in circles if not p.get_fill()],
                "filled": len(ax.patches) - sum(not p.get_fill() for p in ax.patches),
            }
        save(fig, path)

    monkeypatch.setattr(draw_map_module, "save", keep)
    return panels


def test_each_panel_s_legend_counts_every_outcome_as_often_as_its_grid_point_has_it(tmp_path, monkeypatch, rng):
    table, panels = _table(rng), _panels(monkeypatch)
    path = draw_map(table, SCENE, tmp_path / "map.png")
    assert path == tmp_path / "map.png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    for point in OUTCOMES:
        (title,) = [t for t in panels if t.startswith(f"grid point {point}:")]
        assert panels[title]["counts"] == table[table["point"] == point]["outcome"].value_counts().to_dict()


def test_every_drawn_cylinder_is_an_outline_of_the_radius_the_scene_gives_it(tmp_path, monkeypatch, rng):
    table, panels = _table(rng), _panels(monkeypatch)
    draw_map(table, SCENE, tmp_path / "map.png")
    for panel in panels.values():
        assert panel["outlines"] == [0.6] * len(OUTCOMES["on"])  # one per draw; the base cylinder is filled


def test_without_a_scene_the_map_has_the_draws_alone(tmp_path, monkeypatch, rng):
    table, panels = _table(rng), _panels(monkeypatch)
    assert draw_map(table, None, tmp_path / "map.png") == tmp_path / "map.png"
    assert all(p["filled"] == 0 and not p["outlines"] for p in panels.values())  # no tables, no sizes to draw
    assert sum(sum(p["counts"].values()) for p in panels.values()) == len(table)


def test_no_map_is_drawn_when_no_varied_field_is_a_position(tmp_path, rng):
    table = _table(rng)[["sample", "point", "outcome", "success", "vary.world.box.mass"]]
    assert draw_map(table, SCENE, tmp_path / "map.png") is None and not (tmp_path / "map.png").exists()


def test_the_study_report_shows_the_map_over_the_base_scene_the_study_wrote(tmp_path, rng):
    table = _table(rng).assign(reason="", resamples=0, run_dir=str(tmp_path / "runs/s"))
    table = table.rename(columns=lambda c: c.replace(".post.", ".cylinder."))  # the paper scene's obstacle
    table.to_parquet(tmp_path / TABLE)
    scene = scenario_yaml(load_scenario(ROOT / "scenarios/paper/pick_and_carry.yaml"))
    (tmp_path / "base_scenario.yaml").write_text(scene)
    assert yaml.safe_load(scene)["world"]["tables"]  # the map's scene as the runner writes it: a plain mapping
    assert tmp_path / "draws_map.png" in write_report(tmp_path)
    assert "![draws_map](draws_map.png)" in (tmp_path / "report.md").read_text()
