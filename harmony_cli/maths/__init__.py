"""Pure numpy / CasADi maths: Bezier curves, shapes and signed distances, rotations, time scalings, filters.
Nothing here imports the rest of harmony."""
