"""What a study's report breaks its outcomes down by, said of each drawn scene before it runs: how blocked its
written stances are (planning/stance.py's StanceClass: the base, behind the hands as the task writes them at the
box and at its goal, clear of every standing body's margin; inside one but clear after a turn of the hands' targets
about their pivot; or not). A controller's failures gather in the hard kinds of scene; the breakdown shows where,
with each kind's own rate and interval, the headline counting every kind."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from harmony_cli.planning.stance_check import written_stance_class
from harmony_cli.scenario import Scenario
from harmony_cli.tasks.scene_check import SceneCheck

COLUMN = "scene.written_stance"  # the study table's column (study/table.py: a run's `scene`, flattened)


def describer(check: SceneCheck) -> Callable[[Scenario], dict[str, Any]]:
    """A Sampler's `describe`: a scene with a box and a task gets its written stances' class (the robot as the
    scene check builds it, once per robot)."""

    def describe(scenario: Scenario) -> dict[str, Any]:
        if scenario.task is None or scenario.world.box is None:
            return {}
        return {"written_stance": written_stance_class(scenario, check.robot(scenario)).value}

    return describe
