"""Tests of the quasi-static QP drake_sot.quasistatic (Liu, Lober, Padois 2016, eq. 5-11).

Every expected value is computed here independently of the module: equality-constrained
least squares through its KKT system, Lagrange conditions of a two-variable problem,
the minimum-norm distribution of a weight over contact points, scipy's SLSQP on a QP
assembled here from the task definitions, and direct checks of the equilibrium, the
friction pyramids (|f_x|, |f_y| <= mu/sqrt(2) f_z for 4 facets) and the torque bounds.

Conventions (module docstring): sum_i P_i J_i^T w_i + g has zero root rows and actuated
rows tau; g is the gravity term on the left of eq. 1 (+m*9.81 on the vertical root row);
a contact task's w is the force the robot applies on the environment, f = -w the reaction.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.optimize

from drake_sot.quasistatic import FrictionCone, QsTask, QuasiStaticQP, SolveStatus, static_capacity

G0 = 9.81


def skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


def point_jacobian(p: np.ndarray, n: int, joint_part: np.ndarray | None = None) -> np.ndarray:
    """Jacobian of the velocity of a point at p (base frame = world axes) for v = [w_base, v_base, q_dot]."""
    J = np.zeros((3, n))
    J[:, :3] = -skew(p)  # v + w x p = v - [p]x w
    J[:, 3:6] = np.eye(3)
    if joint_part is not None:
        J[:, 6:] = joint_part
    return J


def gravity_term(n: int, mass: float, com: np.ndarray, g_act: np.ndarray | None = None) -> np.ndarray:
    """g of eq. 1 (left side): minus the generalized gravity force [c x (0,0,-mg); (0,0,-mg); ...]."""
    weight = np.array([0.0, 0.0, -mass * G0])
    g = np.zeros(n)
    g[:3] = -np.cross(com, weight)
    g[3:6] = -weight
    if g_act is not None:
        g[6:] = g_act
    return g


def feet_points() -> list[np.ndarray]:
    """8 contact points, 4 per foot, symmetric about the x and y axes of the base, 0.8 m below it."""
    return [
        np.array([x, s * (0.1 + y), -0.8]) for s in (-1.0, 1.0) for x in (-0.05, 0.1) for y in (-0.04, 0.04)
    ]


def generalized(
    tasks: list[QsTask], x_by_name: dict[str, np.ndarray], g: np.ndarray, weighted: bool
) -> np.ndarray:
    """sum_i P_i J_i^T w_i + g computed directly from the task definitions."""
    out = g.copy()
    for t in tasks:
        P = np.eye(g.size) if (weighted or t.projector is None) else t.projector
        out += P @ t.jacobian.T @ x_by_name[t.name]
    return out


def assert_in_pyramids(tasks: list[QsTask], sol, tol: float = 1e-6) -> None:
    """f = -w inside each 4-facet pyramid with normal +z: f_z >= f_min, |f_x|, |f_y| <= mu/sqrt(2) f_z."""
    for t in tasks:
        if t.friction is None:
            continue
        assert t.friction.facets == 4 and t.friction.normal == (0.0, 0.0, 1.0)
        f = -sol.wrenches[t.name]
        lim = t.friction.mu / np.sqrt(2.0) * f[2]
        assert f[2] >= t.friction.min_normal_force - tol, (t.name, f)
        assert abs(f[0]) <= lim + tol and abs(f[1]) <= lim + tol, (t.name, f, lim)


def random_projector(rng: np.random.Generator, n: int) -> np.ndarray:
    """Symmetric, eigenvalues in [0, 1]."""
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    return (Q * rng.uniform(0.0, 1.0, size=n)) @ Q.T


def humanoid_like(rng: np.random.Generator, n_a: int = 6, push: float = 1.0):
    """Floating body on 4 contacts with friction, one projected goal task, a regularised posture."""
    n = 6 + n_a
    mass, com = 20.0, np.array([0.02, -0.01, 0.0])
    pts = [np.array([x, y, -0.6]) for x in (-0.1, 0.1) for y in (-0.1, 0.1)]
    tasks = [
        QsTask(
            f"c{i}",
            point_jacobian(p, n, rng.normal(scale=0.3, size=(3, n_a))),
            weight=1e-3,
            friction=FrictionCone(mu=0.6),
        )
        for i, p in enumerate(pts)
    ]
    hand = point_jacobian(np.array([0.3, 0.1, 0.2]), n, rng.normal(scale=0.5, size=(3, n_a)))
    tasks.append(
        QsTask(
            "hand",
            hand,
            desired=push * np.array([60.0, -20.0, -40.0]),
            weight=2.0,
            projector=random_projector(rng, n),
        )
    )
    ori = np.hstack([np.eye(3), np.zeros((3, 3)), rng.normal(scale=0.5, size=(3, n_a))])
    tasks.append(
        QsTask("ori", ori, desired=np.array([3.0, -2.0, 1.0]), weight=0.5, projector=random_projector(rng, n))
    )
    tasks.append(
        QsTask(
            "posture",
            np.hstack([np.zeros((n_a, 6)), np.eye(n_a)]),
            weight=1e-3,
            projector=random_projector(rng, n),
        )
    )
    g = gravity_term(n, mass, com, rng.normal(scale=2.0, size=n_a))
    return n, tasks, g


# --------------------------------------------------------------------------- closed form
@pytest.mark.parametrize("weighted", [False, True])
def test_matches_kkt_solution_when_no_inequality_is_active(weighted: bool) -> None:
    rng = np.random.default_rng(1)
    n_a, n = 4, 10
    tasks = [
        QsTask(
            "foot", np.hstack([np.eye(6), rng.normal(size=(6, n_a))]), weight=1e-3
        ),  # a 6-D support wrench
        QsTask(
            "hand",
            rng.normal(size=(3, n)),
            desired=np.array([5.0, -3.0, 2.0]),
            weight=4.0,
            projector=random_projector(rng, n),
        ),
        QsTask(
            "head",
            rng.normal(size=(2, n)),
            desired=np.array([1.0, 0.5]),
            weight=0.5,
            projector=random_projector(rng, n),
        ),
        QsTask(
            "posture",
            np.hstack([np.zeros((n_a, 6)), np.eye(n_a)]),
            weight=2e-3,
            projector=random_projector(rng, n),
        ),
    ]
    g = rng.normal(size=n) * 10.0
    # Independent KKT: min sum_j h_j (x_j - d_j)^2  s.t.  E x = -g_root.
    cols = [((np.eye(n) if (weighted or t.projector is None) else t.projector) @ t.jacobian.T) for t in tasks]
    A = np.hstack(cols)
    h = np.concatenate(
        [np.full(t.jacobian.shape[0], t.weight if (weighted or t.desired is None) else 1.0) for t in tasks]
    )
    d = np.concatenate([t.desired if t.desired is not None else np.zeros(t.jacobian.shape[0]) for t in tasks])
    E = A[:6]
    m = h.size
    K = np.block([[2 * np.diag(h), E.T], [E, np.zeros((6, 6))]])
    x = np.linalg.solve(K, np.concatenate([2 * h * d, -g[:6]]))[:m]

    sol = QuasiStaticQP(n).solve(tasks, g, weighted=weighted)
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    got = np.concatenate([sol.wrenches[t.name] for t in tasks])
    np.testing.assert_allclose(got, x, atol=1e-9)
    np.testing.assert_allclose(sol.tau, (A @ x + g)[6:], atol=1e-9)
    assert sol.cost == pytest.approx(float(h @ (x - d) ** 2), rel=1e-9)
    assert sol.root_residual < 1e-9


# --------------------------------------------------------------------------- constraints
@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_solution_satisfies_equilibrium_friction_and_torque_bounds(weighted: bool, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, tasks, g = humanoid_like(rng, push=3.0)
    tau_max = np.full(n - 6, 25.0)
    sol = QuasiStaticQP(n, tau_min=-tau_max, tau_max=tau_max).solve(tasks, g, weighted=weighted)
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    gen = generalized(tasks, sol.wrenches, g, weighted)
    assert np.abs(gen[:6]).max() < 1e-8  # eq. 9b, computed here
    assert sol.root_residual < 1e-8
    np.testing.assert_allclose(sol.tau, gen[6:], atol=1e-9)  # eq. 10
    assert np.all(np.abs(sol.tau) <= tau_max + 1e-6)  # eq. 11
    assert_in_pyramids(tasks, sol)
    # The case is meant to be constrained: some bound or cone is active.
    feet = np.array([-sol.wrenches[f"c{i}"] for i in range(4)])
    on_cone = np.abs(np.abs(feet[:, :2]) - 0.6 / np.sqrt(2) * feet[:, 2:3]) < 1e-6
    on_bound = np.abs(np.abs(sol.tau) - tau_max) < 1e-6
    assert on_cone.any() or on_bound.any()


@pytest.mark.parametrize("last", [4.0, np.inf])  # the last joint bounded or not
def test_torques_sit_on_the_active_bound(last: float) -> None:
    # Fixed base, tau = w + g: the closest admissible torque is the clipped target.
    n = 3
    g = np.array([1.0, -2.0, 0.5])
    d = np.array([10.0, -10.0, 9.0])
    lo, hi = np.array([-4.0, -4.0, -last]), np.array([5.0, 5.0, last])
    sol = QuasiStaticQP(n, n_base=0, tau_min=lo, tau_max=hi).solve([QsTask("joint", np.eye(3), desired=d)], g)
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    np.testing.assert_allclose(sol.tau, np.clip(d + g, lo, hi), atol=1e-9)
    assert sol.tau[0] == pytest.approx(hi[0], abs=1e-9) and sol.tau[1] == pytest.approx(lo[1], abs=1e-9)


def test_goal_beyond_friction_stays_in_the_cone() -> None:
    # A foot asked to push the ground sideways with 400 N while carrying a quarter of 30 kg.
    n, mass, mu = 6, 30.0, 0.5
    pts = [np.array([x, y, -0.8]) for x in (-0.1, 0.1) for y in (-0.1, 0.1)]
    cone = FrictionCone(mu=mu)
    tasks = [QsTask(f"c{i}", point_jacobian(p, n), weight=1e-3, friction=cone) for i, p in enumerate(pts)]
    push = np.array([400.0, 0.0, -mass * G0 / 4])  # w = what the foot applies on the ground
    tasks[0] = QsTask("c0", tasks[0].jacobian, desired=push, friction=cone)
    g = gravity_term(n, mass, np.zeros(3))
    sol = QuasiStaticQP(n, n_base=6).solve(tasks, g)
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    assert_in_pyramids(tasks, sol)
    total = -sum(sol.wrenches[t.name] for t in tasks)
    np.testing.assert_allclose(total, [0.0, 0.0, mass * G0], atol=1e-8)
    # Sideways, all the feet together can resist at most mu/sqrt(2) of the weight.
    assert abs(sol.wrenches["c0"][0]) <= mu / np.sqrt(2) * mass * G0 + 1e-6
    assert sol.wrenches["c0"][0] > 1.0  # it pushes as far as the cones allow, not nothing


def test_impossible_minimum_normal_force_is_infeasible() -> None:
    n, mass = 6, 40.0
    cone = FrictionCone(mu=0.8, min_normal_force=mass * G0)  # each contact >= the whole weight
    tasks = [
        QsTask(f"c{i}", point_jacobian(p, n), weight=1e-3, friction=cone) for i, p in enumerate(feet_points())
    ]
    qp = QuasiStaticQP(n)
    sol = qp.solve(tasks, gravity_term(n, mass, np.zeros(3)))
    assert sol.status == SolveStatus.INFEASIBLE
    assert sol.message
    assert np.isnan(sol.tau).all() and all(np.isnan(w).all() for w in sol.wrenches.values())
    # The next feasible tick of the same structure solves again (no stale warm start).
    light = FrictionCone(mu=0.8, min_normal_force=1.0)
    ok = qp.solve(
        [QsTask(t.name, t.jacobian, weight=1e-3, friction=light) for t in tasks],
        gravity_term(n, mass, np.zeros(3)),
    )
    assert ok.status == SolveStatus.OPTIMAL, ok.message


def test_a_plug_in_solver_answers_with_a_solve_status() -> None:
    """A plug-in's OPTIMAL answer is checked like DAQP's; an answer that is not a SolveStatus
    (a string, the vocabulary before the enum) is FAILED, naming what came back."""
    n, mass = 6, 40.0
    tasks = [
        QsTask(f"c{i}", point_jacobian(p, n), weight=1e-3, friction=FrictionCone(mu=0.8))
        for i, p in enumerate(feet_points())
    ]
    g = gravity_term(n, mass, np.zeros(3))
    reference = QuasiStaticQP(n).solve(tasks, g)
    assert reference.status is SolveStatus.OPTIMAL, reference.message
    x = np.concatenate([reference.wrenches[t.name] for t in tasks])
    plugged = QuasiStaticQP(n, solver=lambda problem: (x, SolveStatus.OPTIMAL, "", 0)).solve(tasks, g)
    assert plugged.status is SolveStatus.OPTIMAL and np.allclose(plugged.tau, reference.tau)
    stringly = QuasiStaticQP(n, solver=lambda problem: (x, "optimal", "", 0)).solve(tasks, g)
    assert stringly.status is SolveStatus.FAILED and "'optimal'" in stringly.message
    assert np.isnan(stringly.tau).all()


def test_the_status_codes_are_the_documented_ones() -> None:
    codes = {"optimal": 0.0, "short": 1.0, "infeasible": 2.0, "failed": 3.0}  # the controller's docstring
    assert {status.value: status.code for status in SolveStatus} == codes
    assert all(SolveStatus.of_code(code) is SolveStatus(name) for name, code in codes.items())
    assert [s for s in SolveStatus if s.fallback] == [SolveStatus.INFEASIBLE, SolveStatus.FAILED]
    with pytest.raises(ValueError, match=r"status code = 4.0: must be one of 0, 1, 2, 3"):
        SolveStatus.of_code(4.0)


def test_unsupported_base_is_infeasible() -> None:
    n = 9
    posture = QsTask("posture", np.hstack([np.zeros((3, 6)), np.eye(3)]), weight=1e-3)
    sol = QuasiStaticQP(n).solve([posture], gravity_term(n, 10.0, np.zeros(3)))
    assert sol.status == SolveStatus.INFEASIBLE
    assert "equilibrium" in sol.message


def test_torque_bounds_the_equilibrium_violates_are_infeasible() -> None:
    # One joint whose torque the contact forces fix: tau = c * sum(w_z) + g_act = -c m g + g_act.
    n, mass, c = 7, 10.0, 0.2
    tasks = [
        QsTask(
            f"c{i}",
            point_jacobian(p, n, np.array([[0.0], [0.0], [c]])),
            weight=1e-3,
            friction=FrictionCone(mu=0.8),
        )
        for i, p in enumerate(feet_points()[:4])
    ]
    g = gravity_term(n, mass, np.array([0.0, -0.1, 0.0]), np.array([1.0]))
    required = -c * mass * G0 + 1.0
    ok = QuasiStaticQP(n, tau_min=[required - 1.0], tau_max=[required + 1.0]).solve(tasks, g)
    assert ok.status == SolveStatus.OPTIMAL and ok.tau[0] == pytest.approx(required, abs=1e-9)
    bad = QuasiStaticQP(n, tau_min=[required + 1.0], tau_max=[required + 5.0]).solve(tasks, g)
    assert bad.status == SolveStatus.INFEASIBLE
    assert np.isnan(bad.tau).all()


# --------------------------------------------------------------------------- static capacity
def _one_joint_on_four_points(n: int = 7, c: float = 0.2):
    """One joint whose torque the contact forces fix: tau = c * sum(w_z) + g_act = -c m g + 1."""
    mass = 10.0
    tasks = [
        QsTask(
            f"c{i}",
            point_jacobian(p, n, np.array([[0.0], [0.0], [c]])),
            weight=1e-3,
            friction=FrictionCone(mu=0.8),
        )
        for i, p in enumerate(feet_points()[:4])
    ]
    g = gravity_term(n, mass, np.array([0.0, -0.1, 0.0]), np.array([1.0]))
    return tasks, g, -c * mass * G0 + 1.0


def test_static_capacity_within_the_bounds() -> None:
    tasks, g, required = _one_joint_on_four_points()
    cap = static_capacity(tasks, g, n_base=6, tau_min=[-20.0], tau_max=[20.0])
    assert cap.feasible and cap.contacts_hold and cap.scale == 1.0 and cap.exceeded == ()
    assert cap.tau[0] == pytest.approx(required, abs=1e-9)


@pytest.mark.parametrize("bound", [0.01, 5.0, 18.0])
def test_static_capacity_finds_the_factor_the_bounds_lack(bound: float) -> None:
    tasks, g, required = _one_joint_on_four_points()  # |required| = 18.62 N·m
    cap = static_capacity(tasks, g, n_base=6, tau_min=[-bound], tau_max=[bound])
    assert not cap.feasible and cap.contacts_hold and cap.exceeded == (0,)
    assert cap.scale == pytest.approx(abs(required) / bound, rel=2e-3)  # bisected to 0.1 %
    assert cap.tau[0] == pytest.approx(required, abs=1e-9)


def test_static_capacity_when_the_contacts_cannot_hold_the_weight() -> None:
    n, mass = 6, 40.0
    cone = FrictionCone(mu=0.8, min_normal_force=mass * G0)  # each point >= the whole weight
    tasks = [
        QsTask(f"c{i}", point_jacobian(p, n), weight=1e-3, friction=cone) for i, p in enumerate(feet_points())
    ]
    cap = static_capacity(tasks, gravity_term(n, mass, np.zeros(3)), n_base=6)
    assert not cap.feasible and not cap.contacts_hold and cap.scale == np.inf
    assert np.isnan(cap.tau).all() and cap.message


def test_static_capacity_without_contacts() -> None:
    g_act = np.array([3.0, -8.0])
    fixed = static_capacity([], g_act, n_base=0, tau_min=[-2.0, -2.0], tau_max=[2.0, 2.0])
    assert not fixed.feasible and fixed.contacts_hold and fixed.exceeded == (0, 1)
    assert fixed.scale == pytest.approx(8.0 / 2.0, rel=2e-3)
    np.testing.assert_array_equal(fixed.tau, g_act)
    assert static_capacity([], g_act, n_base=0, tau_min=[-9.0, -9.0], tau_max=[9.0, 9.0]).feasible
    floating = static_capacity([], gravity_term(8, 10.0, np.zeros(3), g_act), n_base=6)
    assert not floating.contacts_hold and "no contact" in floating.message


# --------------------------------------------------------------------------- standing
def test_standing_on_eight_points_carries_the_weight_evenly() -> None:
    n_a = 4
    n, mass = 6 + n_a, 45.0
    rng = np.random.default_rng(3)
    leg = rng.normal(scale=0.3, size=(3, n_a))
    cone = FrictionCone(mu=0.8)
    tasks = [
        QsTask(f"c{i}", point_jacobian(p, n, leg), weight=1e-3, friction=cone)
        for i, p in enumerate(feet_points())
    ]
    tasks.append(QsTask("posture", np.hstack([np.zeros((n_a, 6)), np.eye(n_a)]), weight=1e-3))
    com = np.array([0.025, 0.0, 0.0])  # centred between the points of each foot
    sol = QuasiStaticQP(n).solve(tasks, gravity_term(n, mass, com))
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    f = np.array([-sol.wrenches[f"c{i}"] for i in range(8)])
    assert f[:, 2].sum() == pytest.approx(mass * G0, rel=1e-12)
    np.testing.assert_allclose(f[:, 2], mass * G0 / 8, rtol=1e-9)
    np.testing.assert_allclose(f[:, :2], 0.0, atol=1e-9)
    np.testing.assert_allclose(sol.wrenches["posture"], 0.0, atol=1e-9)


def test_shifted_com_gives_the_minimum_norm_distribution() -> None:
    n, mass = 6, 45.0
    pts = feet_points()
    tasks = [
        QsTask(f"c{i}", point_jacobian(p, n), weight=1e-3, friction=FrictionCone(mu=0.8))
        for i, p in enumerate(pts)
    ]
    com = np.array([0.04, 0.02, 0.0])
    g = gravity_term(n, mass, com)
    # Independent: minimum-norm contact forces f with sum [p x f; f] = [c x W; W], W = (0, 0, mg).
    Eq = np.hstack([np.vstack([skew(p), np.eye(3)]) for p in pts])
    f_ref = np.linalg.lstsq(Eq, g[:6], rcond=None)[0].reshape(8, 3)
    assert np.all(f_ref[:, 2] > 10.0) and np.all(
        np.abs(f_ref[:, :2]) < 0.8 / np.sqrt(2) * f_ref[:, 2:3]
    )  # no cone active
    sol = QuasiStaticQP(n).solve(tasks, g)
    f = np.array([-sol.wrenches[f"c{i}"] for i in range(8)])
    np.testing.assert_allclose(f, f_ref, atol=1e-8)


# --------------------------------------------------------------------------- priorities
def test_strict_priority_meets_the_higher_task_where_weights_compromise() -> None:
    # Fixed base, 2 joints. Task 1 moves joint 1, task 2 both joints; |tau_1| <= 1.2 couples them.
    J1, J2 = np.array([[1.0, 0.0]]), np.array([[1.0, 1.0]])
    P2 = np.eye(2) - np.linalg.pinv(J1) @ J1  # null-space projector of task 1
    d1, d2, w1, w2 = 1.0, 1.0, 10.0, 1.0
    tasks = [
        QsTask("t1", J1, desired=np.array([d1]), weight=w1),
        QsTask("t2", J2, desired=np.array([d2]), weight=w2, projector=P2),
    ]
    qp = QuasiStaticQP(2, n_base=0, tau_min=[-1.2, -5.0], tau_max=[1.2, 5.0])
    hier = qp.solve(tasks, np.zeros(2))
    weig = qp.solve(tasks, np.zeros(2), weighted=True)
    assert hier.status == weig.status == SolveStatus.OPTIMAL
    # Hierarchical: tau = J1^T w1 + P2 J2^T w2 = (w1, w2): nothing binds, both targets met;
    # the torque seen along task 1 (J1^T)^+ tau is exactly its desired wrench.
    np.testing.assert_allclose([hier.wrenches["t1"][0], hier.wrenches["t2"][0]], [d1, d2], atol=1e-9)
    assert (np.linalg.pinv(J1.T) @ hier.tau)[0] == pytest.approx(d1, abs=1e-9)
    # Weighted: tau_1 = w1 + w2 <= 1.2 binds. Lagrange: x_i = d_i - lam / (2 w_i), x_1 + x_2 = 1.2.
    lam = (d1 + d2 - 1.2) / (1 / (2 * w1) + 1 / (2 * w2))
    x1, x2 = d1 - lam / (2 * w1), d2 - lam / (2 * w2)
    np.testing.assert_allclose([weig.wrenches["t1"][0], weig.wrenches["t2"][0]], [x1, x2], atol=1e-9)
    assert weig.tau[0] == pytest.approx(1.2, abs=1e-9)
    assert abs((np.linalg.pinv(J1.T) @ weig.tau)[0] - d1) > 0.1  # task 1 disturbed by task 2


# --------------------------------------------------------------------------- second solver
@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("seed", [7, 8])
def test_agrees_with_scipy_slsqp_polished_on_its_active_set(weighted: bool, seed: int) -> None:
    rng = np.random.default_rng(seed)
    n, tasks, g = humanoid_like(rng, push=3.0)
    tau_max = np.full(n - 6, 25.0)
    sol = QuasiStaticQP(n, tau_min=-tau_max, tau_max=tau_max).solve(tasks, g, weighted=weighted)
    assert sol.status == SolveStatus.OPTIMAL, sol.message
    # The same QP assembled here from the task definitions: min sum h (x - d)^2, E x = e, G x <= c.
    A = np.hstack(
        [((np.eye(n) if (weighted or t.projector is None) else t.projector) @ t.jacobian.T) for t in tasks]
    )
    h = np.concatenate(
        [np.full(t.jacobian.shape[0], t.weight if (weighted or t.desired is None) else 1.0) for t in tasks]
    )
    d = np.concatenate([t.desired if t.desired is not None else np.zeros(t.jacobian.shape[0]) for t in tasks])
    k = 0.6 / np.sqrt(2)
    # f = -w: f_x <= k f_z, -f_x <= k f_z, f_y <= k f_z, -f_y <= k f_z, -f_z <= 0, written on w.
    Fw = np.array([[-1, 0, k], [1, 0, k], [0, -1, k], [0, 1, k], [0, 0, 1]], dtype=float)
    rows, off = [], 0
    for t in tasks:
        if t.friction is not None:
            block = np.zeros((5, h.size))
            block[:, off : off + 3] = Fw
            rows.append(block)
        off += t.jacobian.shape[0]
    E, e = A[:6], -g[:6]
    G = np.vstack([*rows, A[6:], -A[6:]])
    c = np.concatenate([np.zeros(5 * len(rows)), tau_max - g[6:], tau_max + g[6:]])
    # 1) SLSQP, in scaled variables y = sqrt(h) x (identity Hessian), cost divided by its value at 0.
    s, c0 = np.sqrt(h), float(h @ d**2)
    cons = [
        {"type": "eq", "fun": lambda y: E @ (y / s) - e, "jac": lambda y: E / s},
        {"type": "ineq", "fun": lambda y: c - G @ (y / s), "jac": lambda y: -G / s},
    ]
    res = scipy.optimize.minimize(
        lambda y: np.sum((y - s * d) ** 2) / c0,
        np.zeros(h.size),
        jac=lambda y: 2 * (y - s * d) / c0,
        constraints=cons,
        method="SLSQP",
        options={"ftol": 1e-13, "maxiter": 2000},
    )
    assert res.success, res.message
    x_slsqp = res.x / s
    # SLSQP alone is accurate to ~1e-4 here (the regularised directions weigh 1e-3), so:
    # 2) the KKT system on SLSQP's active set, solved exactly, must be a certified optimum.
    act = np.flatnonzero(c - G @ x_slsqp < 1e-4 * (1.0 + np.abs(c)))
    Ga = G[act]
    K = np.block(
        [
            [2 * np.diag(h), E.T, Ga.T],
            [E, np.zeros((6, 6 + act.size))],
            [Ga, np.zeros((act.size, 6 + act.size))],
        ]
    )
    sol_kkt = np.linalg.lstsq(K, np.concatenate([2 * h * d, e, c[act]]), rcond=None)[0]
    x = sol_kkt[: h.size]
    assert np.abs(K @ sol_kkt - np.concatenate([2 * h * d, e, c[act]])).max() < 1e-8
    assert np.all(G @ x <= c + 1e-8)  # primal feasible
    # Dual feasible: grad = -E^T lam - Ga^T mu with mu >= 0 (by NNLS: the active rows may be
    # dependent, e.g. all 5 faces of an unloaded contact, so the multipliers need not be unique).
    grad = 2 * h * (x - d)
    _, rnorm = scipy.optimize.nnls(np.hstack([Ga.T, E.T, -E.T]), -grad, maxiter=5000)
    assert rnorm < 1e-7 * (1.0 + np.linalg.norm(grad))
    np.testing.assert_allclose(x, x_slsqp, atol=1e-2)  # the polish only refines SLSQP's answer
    got = np.concatenate([sol.wrenches[t.name] for t in tasks])
    np.testing.assert_allclose(got, x, atol=1e-6)
    assert sol.cost == pytest.approx(float(h @ (x - d) ** 2), rel=1e-9)


# --------------------------------------------------------------------------- details
def test_inscribed_pyramid_is_conservative_and_touches_the_cone() -> None:
    rng = np.random.default_rng(5)
    for k in (3, 4, 8):
        normal = rng.normal(size=3)
        cone = FrictionCone(mu=0.7, facets=k, normal=normal, min_normal_force=2.0)
        C, b = cone.halfspaces()
        nrm = normal / np.linalg.norm(normal)
        f = rng.normal(scale=10.0, size=(20000, 3))
        inside = np.all(f @ C.T <= b, axis=1)
        fn = f @ nrm
        ft = np.linalg.norm(f - fn[:, None] * nrm, axis=1)
        assert inside.sum() > 100
        assert np.all(ft[inside] <= 0.7 * fn[inside] + 1e-9) and np.all(fn[inside] >= 2.0)
        # The pyramid's edges lie on the cone: a vertex direction at radius mu is on two facets.
        t1, t2 = cone.tangents()
        assert np.cross(t1, t2) == pytest.approx(nrm)
        a = np.pi / k  # between the facet normals at 0 and 2 pi / k
        vertex = 10.0 * nrm + 0.7 * 10.0 * (np.cos(a) * t1 + np.sin(a) * t2)
        assert np.sum(np.abs(C @ vertex) < 1e-9) == 2


def test_bad_input_is_rejected_with_the_task_name() -> None:
    n = 9
    J = np.hstack([np.eye(3), np.eye(3), np.zeros((3, 3))])
    qp = QuasiStaticQP(n)
    g = np.zeros(n)
    bad = J.copy()
    bad[0, 0] = np.nan
    with pytest.raises(ValueError, match="'hand'.*NaN"):
        qp.solve([QsTask("hand", bad, desired=np.zeros(3))], g)
    with pytest.raises(ValueError, match="unique"):
        qp.solve([QsTask("a", J), QsTask("a", J)], g)
    with pytest.raises(ValueError, match="'foot'.*never projected"):
        qp.solve([QsTask("foot", J, friction=FrictionCone(0.5), projector=np.eye(n))], g)
    with pytest.raises(ValueError, match="'hand'.*desired"):
        qp.solve([QsTask("hand", J, desired=np.zeros(2))], g)
    with pytest.raises(ValueError, match="'hand'.*jacobian"):
        qp.solve([QsTask("hand", J[:, :5])], g)
    with pytest.raises(ValueError, match="weights"):
        qp.solve([QsTask("hand", J, weight=0.0)], g)
    with pytest.raises(ValueError, match="tau_min > tau_max"):
        QuasiStaticQP(n, tau_min=np.ones(3), tau_max=np.zeros(3))
    with pytest.raises(ValueError, match=r"FrictionCone.mu = -1.0: must be finite and >= 0"):
        FrictionCone(mu=-1.0)
    with pytest.raises(ValueError, match=r"FrictionCone.mu = nan"):
        FrictionCone(mu=np.nan)
    with pytest.raises(ValueError, match=r"FrictionCone.min_normal_force = inf N"):
        FrictionCone(mu=0.5, min_normal_force=np.inf)
    with pytest.raises(ValueError, match=r"FrictionCone.facets = 2: must be an integer >= 3"):
        FrictionCone(mu=0.5, facets=2)
    with pytest.raises(ValueError, match=r"n_base = 7: must be <= n = 6"):
        QuasiStaticQP(6, 7)
    with pytest.raises(ValueError, match=r"n = nan"):
        QuasiStaticQP(np.nan)
    with pytest.raises(ValueError, match=r"tau_max must be \(3,\) without NaN"):
        QuasiStaticQP(n, tau_max=[1.0, np.nan, 1.0])


def test_structure_change_and_return_reuse_buffers_correctly() -> None:
    rng = np.random.default_rng(11)
    n, tasks, g = humanoid_like(rng)
    qp = QuasiStaticQP(n)
    a = qp.solve(tasks, g)
    kept = {name: w.copy() for name, w in a.wrenches.items()}
    b = qp.solve(tasks[:-1], g)  # posture removed: another structure
    c = qp.solve(tasks, 1.1 * g)  # back to the first one, other data
    fresh = QuasiStaticQP(n).solve(tasks, 1.1 * g)
    assert a.status == b.status == c.status == SolveStatus.OPTIMAL
    assert "posture" not in b.wrenches
    for name, w in kept.items():  # an earlier solution is not overwritten by later ticks
        np.testing.assert_array_equal(a.wrenches[name], w)
    for name in fresh.wrenches:
        np.testing.assert_allclose(c.wrenches[name], fresh.wrenches[name], atol=1e-9)


@pytest.mark.parametrize("weighted", [False, True])
@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_stacked_qp_gives_the_answer_of_solve(weighted: bool, seed: int) -> None:
    """The stacked entry point (rows J_i P_i and the goal tasks' desired wrenches as arrays) solves the
    same QP as solve() on the tasks; here the goal tasks are not first (contacts, goals, posture)."""
    rng = np.random.default_rng(seed)
    n, tasks, g = humanoid_like(rng, push=3.0)
    tau_max = np.full(n - 6, 25.0)
    qp = QuasiStaticQP(n, tau_min=-tau_max, tau_max=tau_max)
    stacked = qp.stacked([replace(t, projector=None) for t in tasks], weighted=weighted)
    for k in range(3):  # several ticks on one structure (warm-started), other data each time
        scale = 1.0 + 0.2 * k
        rows = np.vstack(
            [t.jacobian if (weighted or t.projector is None) else t.jacobian @ t.projector for t in tasks]
        )
        desired = scale * np.concatenate([t.desired for t in tasks if t.desired is not None])
        ticked = [replace(t, desired=scale * t.desired) if t.desired is not None else t for t in tasks]
        expected = QuasiStaticQP(n, tau_min=-tau_max, tau_max=tau_max).solve(ticked, g, weighted=weighted)
        got = stacked.solve(rows, desired, g)
        assert got.status == expected.status == SolveStatus.OPTIMAL, (got.message, expected.message)
        for t in tasks:
            np.testing.assert_allclose(got.wrenches[t.name], expected.wrenches[t.name], atol=1e-8)
        np.testing.assert_allclose(got.tau, expected.tau, atol=1e-8)
    # Writing into the buffer and handing it back is the same as passing a copy.
    stacked.rows[:] = rows
    np.testing.assert_allclose(stacked.solve(stacked.rows, desired, g).tau, got.tau, atol=1e-12)


def test_stacked_qp_bad_input_names_the_task() -> None:
    rng = np.random.default_rng(5)
    n, tasks, g = humanoid_like(rng)
    qp = QuasiStaticQP(n)
    with pytest.raises(ValueError, match=r"tasks \['hand', 'ori', 'posture'\]: .*give no projector"):
        qp.stacked(tasks)
    stacked = qp.stacked([replace(t, projector=None) for t in tasks])
    rows = np.vstack([t.jacobian for t in tasks])
    desired = np.zeros(stacked.goal_rows)
    assert stacked.goal_rows == 6  # hand and ori
    bad = rows.copy()
    bad[stacked.slices["ori"].start, 0] = np.inf
    with pytest.raises(ValueError, match=r"task 'ori': its rows or desired wrench contain NaN or Inf"):
        stacked.solve(bad, desired, g)
    with pytest.raises(ValueError, match=r"rows must be \(24, 12\), got \(23, 12\)"):
        stacked.solve(rows[1:], desired, g)
    with pytest.raises(ValueError, match=r"desired must be \(6,\), got \(5,\)"):
        stacked.solve(rows, desired[1:], g)
    with pytest.raises(ValueError, match=r"g must be \(12,\)"):
        stacked.solve(rows, desired, g[1:])
