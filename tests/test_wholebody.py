"""Whole-body MPC: sizes from the built problems, derivatives cross-checked, solvers and transcriptions agree."""

import casadi as cs
import numpy as np
import pytest
from conftest import TABLE1

from harmony_cli.maths.shapes import obstacle_shape
from harmony_cli.mpc import nlp
from harmony_cli.mpc.knot_constraints import KnotConstraints
from harmony_cli.mpc.knot_derivatives import KnotDerivatives
from harmony_cli.mpc.knot_params import hand_rows
from harmony_cli.mpc.native_oracle import native_oracle
from harmony_cli.mpc.nlp import NlpSolver, SymbolicNlpSolver
from harmony_cli.mpc.solvers import make_solver
from harmony_cli.mpc.transcription import TraditionalTranscription, make_transcription
from harmony_cli.mpc.wholebody import WholeBodyMPC
from harmony_cli.mpc.wholebody_problem import build_problem
from harmony_cli.scenario import load_scenario
from harmony_cli.tasks.reference import HandReference


def _problem(eva, *overrides):
    scenario = load_scenario(TABLE1, list(overrides))
    transcription = make_transcription(scenario.mpc, eva.n_dof)
    return (
        scenario,
        transcription,
        build_problem(
            eva, transcription, scenario.mpc.weights, scenario.robot.chest_joints, scenario.robot.mirrored_joints
        ),
    )


@pytest.mark.parametrize(
    "transcription, knots, expected",
    [("bezier", 6, 108), ("bezier", 26, 108), ("traditional", 6, 216), ("traditional", 26, 936)],
)
def test_decision_variable_counts_match_the_paper(eva, transcription, knots, expected):
    *_, problem = _problem(eva, f"mpc.transcription={transcription}", f"mpc.knots={knots}")
    assert problem.n_vars == expected


def _hands(eva, scenario, transcription, t=9.0):
    """The hands' reference rows (12 * hands) x K at t + the knot times (what WholeBodyMPC.step takes)."""
    ref = HandReference(scenario.reference, eva.hand_poses_numeric(eva.home))
    return hand_rows(*ref.poses(t + transcription.knot_times))


def _reference(eva, scenario, transcription, t=9.0, chest=0.0, stance=(0.0, 0.0, 0.0, 0.0)):
    """The problem's parameters p: the hands' rows, the chest joints' reference rows (`chest` [rad]), the base's
    stance (x, y, yaw, weight), then the hands' tracking weight multiplier (1)."""
    hands = _hands(eva, scenario, transcription, t)
    K = hands.shape[1]
    chest_rows = np.full((len(scenario.robot.chest_joints), K), chest)
    rows = [hands, chest_rows, np.tile(np.asarray(stance)[:, None], K), np.ones((1, K))]
    return np.vstack(rows).ravel(order="F")


@pytest.mark.parametrize("transcription", ["bezier", "traditional"])
def test_structured_gradient_matches_finite_differences_of_the_named_cost_terms(eva, rng, transcription):
    scenario, tr, problem = _problem(eva, f"mpc.transcription={transcription}", "mpc.knots=6")
    # the chest cost pulled off 0 and the base towards a stance (a blocked stance's posture)
    p = _reference(eva, scenario, tr, chest=0.3, stance=(0.2, -0.1, 2.5, 0.8))
    x = np.tile(eva.home, tr.n_vars // eva.n_dof) + 0.05 * rng.standard_normal(tr.n_vars)
    _, g = KnotDerivatives(problem)(x, p)
    f = lambda z: sum(problem.evaluate_terms(z, p).values())
    eps = 1e-6
    fd = np.array([(f(x + eps * e) - f(x - eps * e)) / (2 * eps) for e in np.eye(tr.n_vars)])
    np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-7)


@pytest.mark.parametrize("transcription", ["bezier", "traditional"])
def test_gauss_newton_hessian_equals_exact_hessian_where_residuals_vanish(eva, rng, transcription):
    scenario, tr, problem = _problem(
        eva,
        f"mpc.transcription={transcription}",
        "mpc.knots=6",
        "mpc.weights={position: 1, orientation: 1, chest_yaw: 10, arm_symmetry: 0.1, "
        "posture: 0, velocity: 0.01, acceleration: 0.001}",
    )
    x = np.tile(eva.home, tr.n_vars // eva.n_dof) + 0.05 * rng.standard_normal(tr.n_vars)
    q_knots = tr.knots(x)[0]
    poses = [eva.hand_poses_numeric(q_knots[:, k]) for k in range(tr.n_knots)]
    positions = np.array([[p.ravel() for p, _ in pose] for pose in poses])
    rotations = np.array([[r for _, r in pose] for pose in poses])
    chest = q_knots[[eva.index(j) for j in scenario.robot.chest_joints]]
    no_stance = np.zeros((4, tr.n_knots))
    unit = np.ones((1, tr.n_knots))  # the hands' task weight multiplier
    p = np.vstack([hand_rows(positions, rotations), chest, no_stance, unit]).ravel(order="F")  # the trajectory itself
    H_gn, _ = KnotDerivatives(problem)(x, p)
    f = sum(problem.terms.values())
    H_exact = np.array(cs.Function("h", [problem.x, problem.p], [cs.hessian(f, problem.x)[0]])(x, p))
    np.testing.assert_allclose(H_gn, H_exact, atol=1e-8)


@pytest.mark.parametrize("transcription", ["bezier", "traditional"])
def test_structured_exact_hessian_equals_casadi_exact_hessian_anywhere(eva, rng, transcription):
    scenario, tr, problem = _problem(eva, f"mpc.transcription={transcription}", "mpc.knots=6")
    p = _reference(eva, scenario, tr)
    x = np.tile(eva.home, tr.n_vars // eva.n_dof) + 0.2 * rng.standard_normal(tr.n_vars)
    H, _ = KnotDerivatives(problem, exact=True)(x, p)
    f = sum(problem.terms.values())
    H_exact = np.array(cs.Function("h", [problem.x, problem.p], [cs.hessian(f, problem.x)[0]])(x, p))
    np.testing.assert_allclose(H, H_exact, atol=1e-9)


@pytest.mark.parametrize("transcription, exact", [("bezier", True), ("bezier", False), ("traditional", True)])
def test_native_oracle_equals_the_numpy_assembly_and_its_reverse_mode_is_the_gradient(eva, rng, transcription, exact):
    scenario, tr, problem = _problem(eva, f"mpc.transcription={transcription}", "mpc.knots=26")
    p = _reference(eva, scenario, tr)
    x = np.tile(eva.home, tr.n_vars // eva.n_dof) + 0.2 * rng.standard_normal(tr.n_vars)
    model = KnotDerivatives(problem, exact=exact)
    oracle = native_oracle(model, p.size)
    assert oracle is not None, "gcc is needed for the native oracle"
    f, g, h = model.evaluate(x, p)
    f_c, g_c, h_c = (np.array(v.nonzeros()) for v in oracle(x, p))
    np.testing.assert_allclose(f_c, f, rtol=1e-12)
    np.testing.assert_allclose(g_c, g, rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(h_c, h, rtol=1e-10, atol=1e-12)
    # reverse mode: seeds on f and on the gradient give adj_f g + H adj_g; p-derivatives are NaN, not zero
    xs, ps = cs.MX.sym("x", x.size), cs.MX.sym("p", p.size)
    out = oracle(xs, ps)
    seed = rng.standard_normal(x.size)
    adj = cs.Function("adj", [xs, ps], [cs.gradient(3.0 * out[0] + cs.dot(seed, out[1]), cs.vertcat(xs, ps))])
    sens = np.array(adj(x, p)).ravel()
    H = np.zeros((x.size, x.size))
    H[model.rows, model.cols] = h
    np.testing.assert_allclose(sens[: x.size], 3.0 * g + H @ seed, rtol=1e-10, atol=1e-10)
    assert np.isnan(sens[x.size :]).all()


def test_bezier_trajectory_satisfies_trapezoidal_integration_better_than_euler(eva, rng):
    """Bezier vs collocation: a smooth Bezier curve sampled at K knots nearly satisfies the collocation rows."""
    scenario, bez, _ = _problem(eva, "mpc.knots=26")
    x = np.tile(eva.home, 6) + 0.3 * rng.standard_normal(bez.n_vars)
    q, dq, _ = bez.knots(x)
    state = np.concatenate([q.ravel("F"), dq.ravel("F")])
    residual = {}
    for integration in ("euler", "trapezoidal"):
        trad = TraditionalTranscription(eva.n_dof, 26, 5.0, integration)
        sym = cs.SX.sym("x", trad.n_vars)
        ((expr, _, _),) = trad.linear_constraints(sym, eva.velocity_limit).values()
        residual[integration] = np.abs(np.array(cs.Function("r", [sym], [expr])(state))).max()
    assert residual["trapezoidal"] < 0.05 * residual["euler"]
    assert residual["trapezoidal"] < 1e-3


def _solve_once(eva, *overrides):
    scenario = load_scenario(TABLE1, list(overrides))
    mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
    command, result = mpc.step(eva.home.copy(), _hands(eva, scenario, mpc.transcription, t=6.0))
    return mpc, command, result


def test_ipopt_and_gauss_newton_sqp_reach_the_same_optimum(eva):
    _, _, ipopt = _solve_once(eva, "mpc.knots=6", "solver.name=ipopt")
    mpc, _, gn = _solve_once(eva, "mpc.knots=6", "solver.name=gauss_newton", "solver.tol=1.0e-9", "solver.max_iter=100")
    assert ipopt.success and gn.success
    np.testing.assert_allclose(gn.x, ipopt.x, atol=2e-4)
    # CasADi's own AD on the full symbolic problem (the path for plugins that reject structured oracles)
    symbolic = SymbolicNlpSolver(mpc.problem, "ipopt", {"ipopt.print_level": 0, "ipopt.sb": "yes"})
    lbx, ubx = mpc.transcription.bounds(
        eva.lower, eva.upper, eva.velocity_limit, eva.home, list(eva.pinned_joints), eva.home[list(eva.pinned_joints)]
    )
    p = _reference(eva, load_scenario(TABLE1, ["mpc.knots=6"]), mpc.transcription, t=6.0)
    reference = symbolic.solve(np.clip(np.tile(eva.home, 6), lbx, ubx), lbx, ubx, p)
    assert reference.success
    np.testing.assert_allclose(ipopt.x, reference.x, atol=2e-4)


def test_levenberg_marquardt_damping_changes_the_steps_but_not_the_optimum(eva):
    converged = ("mpc.knots=6", "solver.name=gauss_newton", "solver.tol=1.0e-9", "solver.max_iter=1000")
    _, _, plain = _solve_once(eva, *converged, "solver.damping=1.0e-6")
    _, _, damped = _solve_once(eva, *converged, "solver.damping=1.0e-2")
    assert plain.success and damped.success and damped.iterations > plain.iterations
    np.testing.assert_allclose(damped.x, plain.x, atol=1e-6)


def test_python_callback_oracles_reach_the_native_oracles_optimum(eva, monkeypatch):
    """Without a C compiler the same derivatives go through Python callbacks: same optimum, only slower."""
    _, _, native = _solve_once(eva, "mpc.knots=6", "solver.name=ipopt")
    monkeypatch.setattr(nlp, "native_oracle", lambda *args: None)
    mpc, _, fallback = _solve_once(eva, "mpc.knots=6", "solver.name=ipopt")
    assert mpc.solver.native is None and native.success and fallback.success
    np.testing.assert_allclose(fallback.x, native.x, atol=1e-8)


def test_solution_starts_at_the_measured_state_with_the_head_pinned(eva):
    mpc, command, result = _solve_once(eva, "solver.name=rti")
    q0, _ = mpc.transcription.readout(result.x, 0.0)
    np.testing.assert_allclose(q0, eva.home, atol=1e-9)
    head = list(eva.pinned_joints)
    np.testing.assert_allclose(mpc.transcription.positions(result.x)[head], 0.0, atol=1e-9)


def test_failed_solve_is_reported_and_the_last_good_plan_is_held(eva):
    scenario = load_scenario(TABLE1, ["mpc.knots=6"])
    mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
    p = _hands(eva, scenario, mpc.transcription, 6.0)
    first, ok = mpc.step(eva.home.copy(), p)
    assert ok.success and not first.held
    plan = mpc.x.copy()
    # an IPOPT limited to one iteration cannot converge from a far-away state: the solve fails
    mpc.solver = make_solver(mpc.problem, load_scenario(TABLE1, ["solver.options={ipopt.max_iter: 1}"]).solver)
    second, failed = mpc.step(first.q + 0.3, p)
    assert not failed.success and second.held
    expected_q, _ = mpc.transcription.readout(mpc.transcription.shift(plan, 0.02), 0.02)
    np.testing.assert_allclose(second.q, expected_q)


NARROW = TABLE1.parent / "narrow_passage.yaml"


def _walled(eva, *overrides):
    """The narrow passage's walls (y = 1.9..2.1) with both hands' references 2.5 m beyond them: the base and the
    hands run into a wall unless the clearance holds."""
    scenario = load_scenario(NARROW, ["mpc.knots=11", *overrides])
    mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
    K = mpc.transcription.n_knots
    poses = eva.hand_poses_numeric(eva.home)
    positions = np.array([[p.ravel() + [0.3, 2.5, 0.0] for p, _ in poses]] * K)
    rotations = np.array([[r for _, r in poses]] * K)
    return scenario, mpc, hand_rows(positions, rotations)


def _footprint_margins(mpc, scenario, x) -> np.ndarray:
    """Numpy geometry (independent of the CasADi model): per knot >= 1, every footprint circle's distance to
    every wall minus its radius and margin."""
    q = mpc.transcription.knots(x)[0][:, 1:]
    out = []
    for wall in scenario.world.obstacles:
        shape = obstacle_shape(wall)
        for cx, cy, r in scenario.robot.footprint:
            c, s = np.cos(q[2]), np.sin(q[2])
            points = np.stack([q[0] + c * cx - s * cy, q[1] + s * cx + c * cy, np.full(q.shape[1], shape.centre[2])], 1)
            out.append(shape.distance(points)[0] - r - wall.margin)
    return np.concatenate(out)


def test_hard_clearance_holds_binds_and_every_solver_reaches_the_same_optimum(eva):
    scenario, mpc, ref = _walled(eva, "solver.name=gauss_newton", "solver.tol=1.0e-10", "solver.max_iter=300")
    _, gn = mpc.step(eva.home.copy(), ref)
    constraints = KnotConstraints(mpc.problem)
    h, lower, _ = constraints.evaluate(gn.x, mpc.params)
    assert gn.success and (lower == 0).all()
    assert h.min() > -1e-8 and h.min() < 1e-6  # feasible and binding: the references pull through the wall
    assert _footprint_margins(mpc, scenario, gn.x).min() >= h.min() - 1e-9  # the soft-min is a lower bound
    lbx, ubx = mpc.transcription.bounds(
        eva.lower, eva.upper, eva.velocity_limit, eva.home, list(eva.pinned_joints), eva.home[list(eva.pinned_joints)]
    )
    x0 = np.clip(mpc._constant(eva.home), lbx, ubx)
    ipopt = make_solver(mpc.problem, load_scenario(NARROW, ["solver.name=ipopt"]).solver)
    assert isinstance(ipopt, NlpSolver)  # the structured path, not the symbolic fallback
    symbolic = SymbolicNlpSolver(mpc.problem, "ipopt", {"ipopt.print_level": 0, "ipopt.sb": "yes"})
    for solver in (ipopt, symbolic):
        result = solver.solve(x0, lbx, ubx, mpc.params)
        assert result.success  # interior point: weakly active joint bounds are approached to ~1e-4
        np.testing.assert_allclose(result.x, gn.x, atol=5e-4)
        cost = lambda x: sum(mpc.problem.evaluate_terms(x, mpc.params).values())
        np.testing.assert_allclose(cost(result.x), cost(gn.x), rtol=1e-6)


def test_clearance_jacobian_and_curvature_match_finite_differences(eva, rng):
    _, mpc, ref = _walled(eva, "solver.name=rti")
    constraints, model = KnotConstraints(mpc.problem), KnotDerivatives(mpc.problem)
    p = mpc.layout.stack(ref, mpc.obstacle_poses)
    x = mpc._constant(eva.home) + 0.05 * rng.standard_normal(mpc.problem.n_vars)
    x[1 :: eva.n_dof] += 1.2  # base y: the footprint near the wall, both sides of the margin
    h, _, C = constraints.evaluate(x, p)
    eps, lam = 1e-6, rng.standard_normal(h.size)
    fd = np.array(
        [
            (constraints.evaluate(x + eps * e, p)[0] - constraints.evaluate(x - eps * e, p)[0]) / (2 * eps)
            for e in np.eye(x.size)
        ]
    ).T
    np.testing.assert_allclose(C, fd, atol=1e-6)
    H = np.zeros((x.size, x.size))
    H[model.rows, model.cols] = model.assemble(constraints.curvature(x, p, lam))
    fd = np.array(
        [
            (constraints.evaluate(x + eps * e, p)[2] - constraints.evaluate(x - eps * e, p)[2]).T @ lam / (2 * eps)
            for e in np.eye(x.size)
        ]
    )
    np.testing.assert_allclose(H, fd, atol=1e-4)


def test_a_state_inside_a_margin_may_stay_but_not_go_deeper(eva):
    _, mpc, ref = _walled(eva, "solver.name=ipopt")  # from a cold start: a globalised solver
    q_now = eva.home.copy()
    q_now[1] = 1.9 - (0.707 / 2) - 0.01  # long side 1 cm from the wall, inside its 3 cm margin
    command, result = mpc.step(q_now, ref)
    constraints = KnotConstraints(mpc.problem)
    h, lower, _ = constraints.evaluate(result.x, mpc.params)
    assert result.success and not command.held and lower.min() < -0.02
    assert (h >= lower - 1e-8).all()
    np.testing.assert_allclose(constraints.lower(result.x, mpc.params), lower, atol=1e-12)  # the solvers' bounds


def test_a_solution_s_constraint_violation_is_the_same_from_compiled_rows_and_from_casadi(eva):
    scenario, mpc, ref = _walled(eva, "solver.name=gauss_newton", "solver.tol=1.0e-10", "solver.max_iter=300")
    _, gn = mpc.step(eva.home.copy(), ref)
    assert gn.max_violation < 1e-8  # converged: feasible
    problem, margins = mpc.problem, KnotConstraints(mpc.problem).margins
    x = gn.x.copy()
    x[1 + eva.n_dof :: eva.n_dof] += 0.4  # every free base y control point 0.4 m further into the wall
    compiled = problem.max_violation(x, gn.p, gn.lbx, gn.ubx, margins)
    assert compiled == pytest.approx(problem.max_violation(x, gn.p, gn.lbx, gn.ubx), rel=1e-12)  # CasADi's VM
    depth = -_footprint_margins(mpc, scenario, x).min()  # numpy geometry: the deepest circle inside the margin
    assert depth > 0.05 and compiled >= depth - 1e-9


def test_a_plan_into_a_wall_gets_a_relaxed_step_that_leaves_no_violated_clearance_row_worse(eva):
    # the measured base 5 cm inside the wall's margin; the warm start runs on 0.18 m per control point into it,
    # deeper at every knot: no step meets every linearised row (they contradict), so the rows violated ask only
    # not to get worse, and the MPC still moves instead of holding a stale plan
    _, mpc, ref = _walled(eva, "solver.name=rti")
    n, q = eva.n_dof, eva.home.copy()
    q[1] = 1.9 - 0.707 / 2 - 0.05
    x0 = np.tile(q, 6)
    for j in range(1, 6):
        x0[j * n : j * n + 3] += j * np.array([0.1, 0.18, 0.1])  # base x, y, yaw
    pinned = list(eva.pinned_joints)
    lbx, ubx = mpc.transcription.bounds(eva.lower, eva.upper, eva.velocity_limit, q, pinned, eva.home[pinned])
    mpc.step(eva.home.copy(), ref)  # parameters (references, obstacles) in place
    result = mpc.solver.solve(x0.copy(), lbx, ubx, mpc.params)
    assert result.success and result.status == "rti_step (clearance relaxed)"
    start = np.clip(x0, lbx, ubx)
    h, lower, C = KnotConstraints(mpc.problem).evaluate(start, mpc.params)
    violated = h < lower
    assert violated.sum() >= 5
    assert (C[violated] @ (result.x - start) >= -1e-9).all()


@pytest.mark.parametrize("transcription", ["bezier", "traditional"])
def test_a_jump_of_the_references_changes_the_joint_velocities_by_at_most_the_acceleration_bound(eva, transcription):
    poses = eva.hand_poses_numeric(eva.home)
    change = {}
    for bound in ("null", "2.0"):
        overrides = [f"mpc.transcription={transcription}", "mpc.knots=6", "solver.name=rti"]
        scenario = load_scenario(TABLE1, [*overrides, f"mpc.max_acceleration={bound}"])
        mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
        t, dt, K = mpc.transcription, scenario.sim.control_dt, mpc.transcription.n_knots
        rotations = np.array([[r for _, r in poses]] * K)
        still = hand_rows(np.array([[p.ravel() for p, _ in poses]] * K), rotations)
        moved = hand_rows(np.array([[p.ravel() + [0.4, 0.3, 0.2] for p, _ in poses]] * K), rotations)
        command, _ = mpc.step(eva.home.copy(), still)
        before = t.readout(t.shift(mpc.x, dt), 0.0)[1][: eva.n_dof]  # the last plan's velocity, one period on
        _, result = mpc.step(command.q, moved)
        assert result.success
        change[bound] = np.abs(t.readout(result.x, 0.0)[1][: eva.n_dof] - before).max()
    assert change["null"] > 10 * 2.0 * dt  # premise: unbounded, the first solve after the jump steps the velocity
    assert change["2.0"] <= 2.0 * dt + 1e-6


def test_a_chest_reference_turns_the_chest_and_the_base_turns_back_as_much_so_the_hands_stay(eva):
    scenario = load_scenario(TABLE1, ["mpc.knots=6", "solver.name=ipopt"])
    mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
    K, chest, yaw = mpc.transcription.n_knots, eva.index(scenario.robot.chest_joints[0]), eva.base_joints[2]
    poses = eva.hand_poses_numeric(eva.home)
    still = hand_rows(np.array([[p.ravel() for p, _ in poses]] * K), np.array([[r for _, r in poses]] * K))
    _, result = mpc.step(eva.home.copy(), still, chest_ref=np.full((1, K), 0.4))
    assert result.success
    q_end = mpc.transcription.knots(result.x)[0][:, -1]
    assert q_end[chest] > 0.2  # pulled towards 0.4 within the horizon's velocity and acceleration costs
    assert abs(q_end[chest] + (q_end[yaw] - eva.home[yaw])) < 0.05  # the arms take up the rest (3 deg)
    hands = np.array([p.ravel() for p, _ in eva.hand_poses_numeric(q_end)])
    assert np.abs(hands - [p.ravel() for p, _ in poses]).max() < 0.02


def test_a_larger_task_weight_makes_the_posture_cost_yield(eva):
    """Hands asked 20 cm higher against a stiff posture cost: a tenfold task weight leaves them less than half as far
    short at the horizon's end."""
    scenario = load_scenario(TABLE1, ["mpc.knots=6", "solver.name=ipopt", "mpc.weights.posture=0.2"])
    K = scenario.mpc.knots
    poses = eva.hand_poses_numeric(eva.home)
    raised = np.array([[p.ravel() + [0.0, 0.0, 0.2] for p, _ in poses]] * K)
    short = {}
    for weight in (1.0, 10.0):
        mpc = WholeBodyMPC(eva, scenario, scenario.sim.control_dt)
        _, result = mpc.step(
            eva.home.copy(), hand_rows(raised, np.array([[r for _, r in poses]] * K)), task_weight=weight
        )
        assert result.success
        q_end = mpc.transcription.knots(result.x)[0][:, -1]
        hands = np.array([p.ravel() for p, _ in eva.hand_poses_numeric(q_end)])
        short[weight] = float(np.abs(hands - raised[-1]).max())
    assert short[1.0] > 0.02  # premise: the posture cost holds the hands more than 2 cm short
    assert short[10.0] < 0.5 * short[1.0]
