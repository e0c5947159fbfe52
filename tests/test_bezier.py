"""Properties of the Bernstein/Bezier helpers, stated as sentences."""

from __future__ import annotations

import casadi as ca
import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from harmony_cli.maths.bezier import (
    bernstein_basis,
    convex_hull_box,
    derivative_matrix,
    difference_matrix,
    evaluate,
    shift_matrix,
)

SETTINGS = settings(max_examples=50, deadline=None)

n_ctrls = st.integers(1, 10)
horizons = st.floats(0.1, 10.0)
coords = st.floats(-10.0, 10.0, allow_nan=False, allow_infinity=False)
knots = st.lists(
    st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1e-9, 0.5, 1 - 1e-9, 1.0])),
    max_size=10,
).map(lambda extra: np.array([0.0, 1.0, *extra]))
interior = st.lists(st.floats(0.01, 0.99), min_size=1, max_size=8).map(np.array)


@st.composite
def control_points(draw, min_ctrl: int = 1) -> np.ndarray:
    n_ctrl = draw(st.integers(min_ctrl, 10))
    dim = draw(st.integers(1, 3))
    return draw(arrays(np.float64, (dim, n_ctrl), elements=coords))


def _scale(X: np.ndarray) -> float:
    return 1.0 + float(np.abs(X).max())


@SETTINGS
@given(control_points(), horizons)
def test_curve_starts_at_first_and_ends_at_last_control_point(X, T):
    ends = evaluate(X, [0.0, 1.0], horizon=T)
    np.testing.assert_allclose(ends[:, 0], X[:, 0], rtol=0, atol=1e-12)
    np.testing.assert_allclose(ends[:, 1], X[:, -1], rtol=0, atol=1e-12)


@SETTINGS
@given(n_ctrls, knots)
def test_basis_rows_are_nonnegative_and_sum_to_one(n_ctrl, s):
    B = bernstein_basis(n_ctrl, s)
    assert B.shape == (s.size, n_ctrl)
    assert np.all(B >= 0.0)
    np.testing.assert_allclose(B.sum(axis=1), 1.0, rtol=0, atol=1e-12)


@SETTINGS
@given(control_points(), knots)
def test_every_curve_sample_lies_in_the_control_point_box(X, s):
    lo, hi = convex_hull_box(X)
    samples = evaluate(X, s)
    assert np.all(samples >= lo[:, None] - 1e-9)
    assert np.all(samples <= hi[:, None] + 1e-9)


@SETTINGS
@given(control_points(), interior, horizons)
def test_first_time_derivative_matches_central_differences_in_time(X, s, T):
    h = 1e-5  # step in s, i.e. 1e-5 * T seconds
    fd = (evaluate(X, s + h, horizon=T) - evaluate(X, s - h, horizon=T)) / (2 * h * T)
    analytic = evaluate(X, s, order=1, horizon=T)
    np.testing.assert_allclose(analytic, fd, rtol=1e-4, atol=1e-5 * _scale(X) / T)


@SETTINGS
@given(control_points(), interior, horizons)
def test_second_time_derivative_matches_differences_of_the_first(X, s, T):
    h = 1e-5
    v_plus, v_minus = (evaluate(X, s + d, order=1, horizon=T) for d in (h, -h))
    fd = (v_plus - v_minus) / (2 * h * T)
    analytic = evaluate(X, s, order=2, horizon=T)
    np.testing.assert_allclose(analytic, fd, rtol=1e-4, atol=1e-4 * _scale(X) / T**2)


def test_time_derivatives_scale_with_inverse_powers_of_the_horizon():
    X = np.array([[0.0, 1.0, 4.0, 2.0, -3.0]])
    s = np.linspace(0.0, 1.0, 7)
    for order in (1, 2, 3):
        unit = evaluate(X, s, order=order, horizon=1.0)
        assert np.abs(unit).max() > 1.0
        np.testing.assert_allclose(evaluate(X, s, order=order, horizon=2.5), unit / 2.5**order)


@SETTINGS
@given(n_ctrls, st.integers(0, 12), knots, horizons)
def test_derivatives_beyond_the_degree_are_zero_with_the_right_shape(n_ctrl, order, s, T):
    D = difference_matrix(n_ctrl, order, T)
    M = derivative_matrix(n_ctrl, s, order, T)
    assert D.shape == (max(n_ctrl - order, 0), n_ctrl)
    assert M.shape == (s.size, n_ctrl)
    if order >= n_ctrl:
        assert not M.any()
    if order == 0:
        np.testing.assert_array_equal(D, np.eye(n_ctrl))


@SETTINGS
@given(n_ctrls, knots)
def test_casadi_basis_equals_numpy_basis(n_ctrl, s):
    expected = bernstein_basis(n_ctrl, s)
    for sym in (ca.SX, ca.MX):
        s_sym = sym.sym("s", s.size, 1)
        B_sym = bernstein_basis(n_ctrl, s_sym)
        assert isinstance(B_sym, sym)
        f = ca.Function("basis", [s_sym], [B_sym])
        np.testing.assert_allclose(np.array(f(s)), expected, rtol=0, atol=1e-12)


@SETTINGS
@given(control_points(), knots, st.integers(0, 3), horizons)
def test_casadi_evaluate_equals_numpy_evaluate(X, s, order, T):
    expected = evaluate(X, s, order, T)
    M = derivative_matrix(X.shape[1], s, order, T)
    atol = 1e-12 * _scale(X) * (1.0 + np.abs(M).sum(axis=1).max())
    X_sym = ca.SX.sym("X", *X.shape)
    f = ca.Function("curve", [X_sym], [evaluate(X_sym, s, order, T)])
    np.testing.assert_allclose(np.array(f(X)), expected, rtol=0, atol=atol)
    from_dm = evaluate(ca.DM(X), s, order, T)
    assert isinstance(from_dm, ca.DM)
    np.testing.assert_allclose(np.array(from_dm), expected, rtol=0, atol=atol)


@SETTINGS
@given(control_points(), st.floats(0.0, 0.9), knots, horizons)
def test_shifted_curve_is_the_tail_of_the_original_reparameterised(X, tau, s, T):
    Y = X @ shift_matrix(X.shape[1], tau)
    mapped = tau + (1 - tau) * s
    np.testing.assert_allclose(evaluate(Y, s), evaluate(X, mapped), rtol=0, atol=1e-9 * _scale(X))
    np.testing.assert_allclose(
        evaluate(Y, s, order=1, horizon=(1 - tau) * T),
        evaluate(X, mapped, order=1, horizon=T),
        rtol=1e-9,
        atol=1e-9 * _scale(X) * X.shape[1] / T,
    )
    np.testing.assert_array_equal(Y[:, -1], X[:, -1])


@SETTINGS
@given(n_ctrls)
def test_shift_by_zero_is_the_identity(n_ctrl):
    np.testing.assert_array_equal(shift_matrix(n_ctrl, 0.0), np.eye(n_ctrl))


@SETTINGS
@given(
    st.integers(2, 10), horizons, arrays(np.float64, (3,), elements=coords), arrays(np.float64, (3,), elements=coords)
)
def test_straight_line_has_constant_velocity_on_every_hodograph_point(n_ctrl, T, a, b):
    n = n_ctrl - 1
    X = a[:, None] + b[:, None] * T * np.arange(n_ctrl) / n
    V = X @ difference_matrix(n_ctrl, 1, T).T
    np.testing.assert_allclose(V, np.repeat(b[:, None], n, axis=1), rtol=1e-9, atol=1e-9 * (1 + np.abs(a).max()) / T)


@SETTINGS
@given(control_points(min_ctrl=2), horizons)
def test_end_velocities_are_degree_over_horizon_times_end_differences(X, T):
    n = X.shape[1] - 1
    v = evaluate(X, [0.0, 1.0], order=1, horizon=T)
    np.testing.assert_allclose(v[:, 0], n / T * (X[:, 1] - X[:, 0]), rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(v[:, 1], n / T * (X[:, -1] - X[:, -2]), rtol=1e-12, atol=1e-12)
