"""harmony: YAML-driven whole-body Bezier MPC experiments for dual-arm mobile manipulators."""

import os

# One BLAS thread (unless the user set it): the loop's matrices are small (~40-400 rows) and its steps run one
# after another; a second BLAS thread only waits for a core, and on a loaded machine (a study's other run, a
# browser) a small product then waits hundreds of times longer than it computes. Set before numpy loads its BLAS.
for _variable in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_variable, "1")

__version__ = "0.2.0"
