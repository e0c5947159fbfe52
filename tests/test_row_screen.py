"""The screened dense QP (mpc/row_screen.py) finds the optimum of the QP over all its rows."""

import casadi as cs
import numpy as np
import pytest

from harmony_cli.mpc.knot_rows import KnotRows
from harmony_cli.mpc.row_screen import DenseRows, ScreenedQP


def _random_qp(rng: np.random.Generator, n: int, m: int):
    """A strictly convex QP whose rows have random slack at z = 0: some bind at the optimum, most do not."""
    M = rng.standard_normal((n, n))
    H = M @ M.T + n * np.eye(n)
    G = rng.standard_normal((m, n))
    lo = -rng.uniform(0.05, 5.0, m)
    hi = np.where(rng.random(m) < 0.5, -lo, np.inf)
    return H, 10.0 * rng.standard_normal(n), G, lo, hi


def _full_qp(H, g, G, lo, hi, solver: str) -> np.ndarray:
    structure = {"h": cs.Sparsity.dense(*H.shape), "a": cs.Sparsity.dense(*G.shape)}
    qp = cs.conic("full", solver, structure, _OPTIONS[solver])
    return np.array(qp(h=H, g=g, a=G, lba=lo, uba=hi, lbx=-np.inf, ubx=np.inf)["x"]).ravel()


_OPTIONS = {"daqp": {"error_on_fail": True}, "qpoases": {"printLevel": "none", "error_on_fail": True}}


@pytest.mark.parametrize("seed", range(5))
def test_screened_qp_equals_the_full_qp_over_a_sequence_of_steps(seed):
    """Solved again and again with new data (as in an MPC), the screened QP's solution is the full QP's, from two
    different solvers, while it gives its solver fewer rows than there are."""
    rng = np.random.default_rng(seed)
    n, m = 30, 120
    H, g, G, lo, hi = _random_qp(rng, n, m)
    screened = ScreenedQP("daqp", {"error_on_fail": False}, cs.Sparsity.dense(n, n), m)
    rows = []
    for _ in range(8):
        g = g + rng.standard_normal(n)  # the next step: a moved target, nearby linearisation
        G = G + 0.05 * rng.standard_normal(G.shape)
        out = screened.solve(H.ravel("F"), g, np.full(n, -np.inf), np.full(n, np.inf), DenseRows(G), lo, hi)
        assert out.success
        np.testing.assert_allclose(out.z, _full_qp(H, g, G, lo, hi, "daqp"), rtol=1e-9, atol=1e-9)
        np.testing.assert_allclose(out.z, _full_qp(H, g, G, lo, hi, "qpoases"), rtol=1e-6, atol=1e-6)
        rows.append(out.rows)
    assert max(rows) < m


def test_a_dropped_row_that_the_step_violates_is_added():
    """A row far from its bound at the last step but crossed by the next one is found and added (two QPs)."""
    n = 4
    screened = ScreenedQP("daqp", {"error_on_fail": False}, cs.Sparsity.dense(n, n), 1)
    H, G, lo, hi = np.eye(n).ravel("F"), np.array([[1.0, 0, 0, 0]]), np.array([-np.inf]), np.array([1.0])
    first = screened.solve(H, np.full(n, -0.1), np.full(n, -np.inf), np.full(n, np.inf), DenseRows(G), lo, hi)
    assert first.rows == 0 and first.z[0] == pytest.approx(0.1)  # unconstrained: the row holds, it stays out
    second = screened.solve(H, np.array([-5.0, 0, 0, 0]), np.full(n, -np.inf), np.full(n, np.inf), DenseRows(G), lo, hi)
    assert second.solves == 2 and second.z[0] == pytest.approx(1.0)


def test_knot_rows_act_like_the_dense_rows_they_stand_for():
    """|G| v, G z and G[rows] from the per-knot Jacobians equal those of G formed whole (as KnotConstraints.evaluate
    forms C: J_k[j, i] b_k[a] on variable a * n_dof + i), the taken rows to the bit."""
    rng = np.random.default_rng(3)
    K, m, nd, npos, extra = 6, 4, 5, 3, 2
    J, B = rng.standard_normal((K - 1, m, nd)), rng.random((K - 1, npos))
    free = rng.random(nd * npos + extra) < 0.8
    A = rng.standard_normal((7, int(free.sum())))
    C = np.zeros((m * (K - 1), free.size))
    C[:, : nd * npos] = np.einsum("kji,ka->kjai", J, B).reshape(m * (K - 1), -1)
    G = np.vstack([A, C[:, free]])
    rows = KnotRows(A, np.abs(A), J, B, free)
    v = rng.random(int(free.sum()))
    np.testing.assert_allclose(rows.reach(v), np.abs(G) @ v, rtol=1e-12)
    np.testing.assert_allclose(rows.times(v), G @ v, rtol=1e-12)
    taken = np.sort(rng.choice(G.shape[0], 9, replace=False))
    assert np.array_equal(rows.take(taken), G[taken])


def test_a_prepared_screened_qp_builds_no_solver_while_it_solves_and_finds_what_an_unprepared_one_finds(monkeypatch):
    rng = np.random.default_rng(11)
    n, m = 20, 70
    H, g, G, lo, hi = _random_qp(rng, n, m)
    built = []
    conic = cs.conic
    monkeypatch.setattr(cs, "conic", lambda *a, **k: built.append(a[0]) or conic(*a, **k))
    prepared = ScreenedQP("daqp", {"error_on_fail": False}, cs.Sparsity.dense(n, n), m)
    prepared.prepare()
    assert len(built) == 1 + -(-m // 16)  # one per padded row count, and one without rows
    plain = ScreenedQP("daqp", {"error_on_fail": False}, cs.Sparsity.dense(n, n), m)
    free = np.full(n, -np.inf), np.full(n, np.inf)
    for _ in range(6):
        g = g + 3.0 * rng.standard_normal(n)
        before = len(built)
        a = prepared.solve(H.ravel("F"), g, *free, DenseRows(G), lo, hi)
        assert len(built) == before
        b = plain.solve(H.ravel("F"), g, *free, DenseRows(G), lo, hi)
        assert a.success and np.array_equal(a.z, b.z)
