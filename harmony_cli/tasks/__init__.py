"""What the hands should do: fixed hand trajectories (Table 1), the phase schedule, the two-stage references
(phase goals -> task-space planner -> hand references at the whole-body MPC's knots) and obstacle motion."""
