"""The planning layer: what the hands should do next, decided from the observation and the scene.

One pipeline, built once per run from the robot and the scenario (`Planner`, planner.py) and asked every control
step for the whole-body MPC's hand targets (`Planner.plan(t, observation, knot_times)`):

1. Stances (stance*.py): for each phase that works at a place, the base pose that reaches it, chosen by one
   optimisation over the whole scene (reach, the footprint's clearance with obstacles' margins as a preference and
   their bodies as a hard limit, the chest's range), before the run.
2. Route (route.py, visibility.py, plan_seed.py): the shortest planar way round obstacles and
   tables, wide enough for the base, through a stance where one is needed; it seeds the hands' plan.
3. Hands (hand_mpc.py, hand_sqp.py, plan_horizon.py): the task-space MPC, a Bezier SQP whose clearance rows carry
   exact L1 slack (every QP feasible), its horizon from the rate bounds in closed form, its outcomes typed
   (hand_plan.py).
"""

from harmony_cli.planning.planner import Planner

__all__ = ["Planner"]
