"""The two MPCs and harmony's CasADi layer: problem and result types, code generation and its cache, knot
derivatives, the native oracle, solvers and their registry, transcriptions, the whole-body MPC (its structure built
once per process: structures.py) and the task-space planner. Controllers take observations and numbers, never the
simulator."""
