"""Timing of the quasi-static QP of Liu, Lober, Padois 2016 (eq. 9-11 and the eq. 5-7 baseline), per
solver, in one run.

    python benchmarks/bench_generalized.py [--ticks 500] [--baseline 85d3c92] [--pairs 3] [--update-only]

The last tables time the ``GeneralizedHierarchyController``'s whole update in ``table_pounding``
(physics), alone and then beside the tree of ``--baseline`` simulated at the same time
(``--pairs`` times); ``--update-only`` prints those tables only.

The load is the paper's table-pounding stack (section 4.1, 18 tasks, total task
dimension 76 here) on a 36-dof floating-base humanoid (6 root + 30 actuated):
CoM xy (2), right/left hand position (3+3) and orientation (3+3), right/left hand
force (1+1), head orientation (1), back posture (5), whole-body posture (30,
Jacobian [0 | I], regularised), and 8 foot contact points (4 per foot, 3-D forces,
Coulomb cones mu = 0.8 on 4 facets, regularised). The Jacobians are random but shaped
like a humanoid's: the root columns are the rigid-body ones of each point
([-[p]x | I] for a position, [I | 0] for an orientation), the joint columns are random
on the joints of the chain that moves the point, zero elsewhere. The projectors are
the generalized projectors of the paper's hierarchy (CoM strictly above all, posture
below all, hand orientations, back and head below the hand position and force tasks,
right hand force halfway through a transition over the right hand position task,
contacts never projected) from ``drake_sot.generalized.generalized_projectors``.

A control trajectory of ``--ticks`` ticks is solved: the Jacobians, gravity and targets
vary smoothly tick to tick (as in a controller, where active-set solvers can warm-start),
with targets large enough that friction cones and torque bounds become active. Every
solver solves the same QP through ``QuasiStaticQP`` (same build, same final feasibility
check), calls interleaved tick by tick so that all see the same machine load. Times are
the whole ``solve`` call: QP build + solve + check. The ``full tick`` row adds the 18
generalized projectors computed every tick.

Solvers (the ones not installed are skipped; ``pip install quadprog proxsuite piqp``):
- daqp (the module's own): workspace kept, warm start from the last active set; also
  timed cold (a new workspace every tick).
- quadprog (Goldfarb-Idnani): the factorized form (R^-1 of the diagonal Hessian is
  trivial), one-sided rows, cold every tick (it has no warm start).
- proxsuite (dense ProxQP): one QP object updated every tick, warm-started from the last
  result, eps_abs = 1e-9.
- piqp (dense interior point): set up every tick, eps_abs = 1e-9.
- drake-osqp: Drake's OSQP through pydrake.solvers, MathematicalProgram built once and its
  coefficients updated every tick, eps 1e-7, polishing on.
"not optimal" counts answers that are not "optimal" after QuasiStaticQP's own check
(equilibrium to 1e-9 relative, friction and torque rows to 1e-6): a solver whose answer
violates a row by more than that is reported as failed, whatever its own status says.
"""

from __future__ import annotations

import argparse
import os
import pathlib
import statistics
import subprocess
import sys
import tempfile
import time

import numpy as np
from baseline_tree import extract

from drake_sot.quasistatic import FrictionCone, QsProblem, QsTask, QuasiStaticQP, SolveStatus

N_BASE, N_A = 6, 30
N = N_BASE + N_A
MASS, G0 = 33.0, 9.81  # iCub-like
# Actuated joints: left leg 0-5, right leg 6-11, back 12-16, neck 17, left arm 18-23, right arm 24-29.
LLEG, RLEG, BACK, NECK = range(6), range(6, 12), range(12, 17), range(17, 18)
LARM, RARM = range(18, 24), range(24, 30)
TAU_MAX = np.concatenate([np.full(12, 40.0), np.full(5, 30.0), [5.0], np.full(12, 12.0)])


def skew(p: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -p[2], p[1]], [p[2], 0.0, -p[0]], [-p[1], p[0], 0.0]])


class Humanoid:
    """Smoothly varying random task data of the 18-task stack; ``tick(k)`` gives tick k's."""

    def __init__(self, seed: int = 0) -> None:
        rng = np.random.default_rng(seed)
        self.rng = rng
        # Operational points relative to the base (world-aligned axes) [m].
        self.p = {
            "rh": np.array([0.25, -0.2, 0.1]),
            "lh": np.array([0.25, 0.2, 0.1]),
            "com": np.array([0.02, 0.0, 0.05]),
            "head": np.array([0.0, 0.0, 0.35]),
        }
        self.feet = [
            np.array([x, s * 0.07 + y, -0.5]) for s in (-1, 1) for x in (-0.04, 0.08) for y in (-0.025, 0.025)
        ]
        self.chain = {
            "rh": list(BACK) + list(RARM),
            "lh": list(BACK) + list(LARM),
            "head": list(BACK) + list(NECK),
            "com": list(range(N_A)),
        }
        self.base = {
            k: rng.normal(scale=0.3, size=(3, N_A)) for k in ("rh", "lh", "rho", "lho", "head", "com")
        }
        self.leg = [rng.normal(scale=0.25, size=(3, 6)) for _ in self.feet]
        self.dir = {k: rng.normal(scale=0.05, size=v.shape) for k, v in self.base.items()}
        self.g_ac = rng.normal(scale=3.0, size=N_A)
        self.targets = {
            "com": 40.0 * rng.normal(size=2),
            "rh": 25.0 * rng.normal(size=3),
            "lh": 25.0 * rng.normal(size=3),
            "rho": 3.0 * rng.normal(size=3),
            "lho": 3.0 * rng.normal(size=3),
            "rhf": np.array([-30.0]),
            "lhf": np.array([-15.0]),
            "head": np.array([0.5]),
            "back": 5.0 * rng.normal(size=5),
        }

    def _joint_part(self, key: str, chain_key: str, s: float) -> np.ndarray:
        J = np.zeros((3, N_A))
        cols = self.chain[chain_key]
        J[:, cols] = (self.base[key] + s * self.dir[key])[:, cols]
        return J

    def tasks(self, k: int) -> tuple[list[QsTask], np.ndarray]:
        """Tasks (without projectors) and g at tick k."""
        s = np.sin(2 * np.pi * k / 200.0)
        c = np.cos(2 * np.pi * k / 130.0)
        out: list[QsTask] = []

        def pos(name):
            p = self.p[name] + 0.02 * np.array([s, c, s * c])
            return np.hstack([-skew(p), np.eye(3), self._joint_part(name, name, s)])

        def ori(key, chain):
            return np.hstack([np.eye(3), np.zeros((3, 3)), self._joint_part(key, chain, c)])

        tg = self.targets
        com = pos("com")[:2]
        out.append(QsTask("com", com, desired=tg["com"] * (1 + 0.3 * s), weight=10.0))
        Jrh, Jlh = pos("rh"), pos("lh")
        out.append(QsTask("rh", Jrh, desired=tg["rh"] * (1 + 0.5 * c), weight=1.0))
        out.append(QsTask("lh", Jlh, desired=tg["lh"] * (1 - 0.5 * s), weight=1.0))
        out.append(QsTask("rho", ori("rho", "rh"), desired=tg["rho"] * (1 + 0.2 * s), weight=0.1))
        out.append(QsTask("lho", ori("lho", "lh"), desired=tg["lho"] * (1 + 0.2 * c), weight=0.1))
        out.append(QsTask("rhf", Jrh[2:3], desired=tg["rhf"] * (1 + 0.5 * s), weight=2.0))
        out.append(QsTask("lhf", Jlh[2:3], desired=tg["lhf"] * (1 + 0.5 * c), weight=2.0))
        out.append(QsTask("head", ori("head", "head")[2:3], desired=tg["head"] * c, weight=0.1))
        back = np.zeros((5, N))
        back[:, N_BASE + 12 : N_BASE + 17] = np.eye(5)
        out.append(QsTask("back", back, desired=tg["back"] * (1 + 0.3 * s), weight=0.1))
        out.append(QsTask("posture", np.hstack([np.zeros((N_A, N_BASE)), np.eye(N_A)]), weight=1e-3))
        cone = FrictionCone(mu=0.8, facets=4)
        for i, (p, L) in enumerate(zip(self.feet, self.leg, strict=True)):
            J = np.zeros((3, N))
            J[:, :3], J[:, 3:6] = -skew(p), np.eye(3)
            cols = N_BASE + np.array(list(LLEG if i < 4 else RLEG))
            J[:, cols] = L * (1 + 0.1 * s)
            out.append(QsTask(f"foot{i}", J, weight=1e-3, friction=cone))
        cpos = self.p["com"] + 0.01 * np.array([s, c, 0.0])
        g = np.concatenate(
            [np.cross(cpos, [0.0, 0.0, MASS * G0]), [0.0, 0.0, MASS * G0], self.g_ac * (1 + 0.2 * s)]
        )
        return out, g


def priority_alpha(names: list[str], rhf_over_rh: float = 0.5) -> np.ndarray:
    """alpha[i, j]: priority of task j with respect to task i (Liu, Lober, Padois 2016, eq. 4, 4.1)."""
    idx = {n: i for i, n in enumerate(names)}
    a = np.zeros((len(names), len(names)))
    goal = ["com", "rh", "lh", "rho", "lho", "rhf", "lhf", "head", "back"]
    for n in goal + ["posture"]:
        if n != "com":
            a[idx[n], idx["com"]] = 1.0  # CoM strictly above every other task
    for j in goal:
        a[idx["posture"], idx[j]] = 1.0  # posture below every goal task
    for low in ("rho", "lho", "back", "head"):
        for high in ("rh", "lh", "rhf", "lhf"):
            a[idx[low], idx[high]] = 1.0
    a[idx["rh"], idx["rhf"]] = rhf_over_rh  # mid-transition (eq. 12)
    a[idx["rhf"], idx["rh"]] = 1.0 - rhf_over_rh
    a[idx["lhf"], idx["lh"]] = 1.0  # left hand force below left hand position (idle)
    return a


def with_projectors(tasks: list[QsTask], P: np.ndarray) -> list[QsTask]:
    return [
        t if t.friction is not None else QsTask(t.name, t.jacobian, t.desired, t.weight, P[i])
        for i, t in enumerate(tasks)
    ]


# --------------------------------------------------------------------------- other solvers
def _split_ineq(p: QsProblem):
    up, lo = np.isfinite(p.upper), np.isfinite(p.lower)
    return up, lo


def make_quadprog():
    import quadprog

    def solve(p: QsProblem):
        up, lo = _split_ineq(p)
        Cmat = np.vstack([p.A_eq, -p.A_in[up], p.A_in[lo]]).T
        b = np.concatenate([p.b_eq, -p.upper[up], p.lower[lo]])
        try:  # G = R^-1 with diag(h) = R^T R: the factorized form skips quadprog's Cholesky
            x = quadprog.solve_qp(
                np.diag(1.0 / np.sqrt(p.h)), p.h * p.d, Cmat, b, p.A_eq.shape[0], factorized=True
            )[0]
        except ValueError as e:
            return (
                None,
                (SolveStatus.INFEASIBLE if "inconsistent" in str(e) else SolveStatus.FAILED),
                str(e),
                0,
            )
        return x, SolveStatus.OPTIMAL, "", 0

    return solve


def make_proxsuite():
    import proxsuite

    state = {}

    def solve(p: QsProblem):
        m, ne, ni = p.h.size, p.A_eq.shape[0], p.A_in.shape[0]
        lo, up = np.maximum(p.lower, -1e20), np.minimum(p.upper, 1e20)
        qp = state.get("qp")
        if qp is None:
            qp = proxsuite.proxqp.dense.QP(m, ne, ni)
            qp.settings.eps_abs = 1e-9
            qp.settings.eps_rel = 0.0
            qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
            qp.init(np.diag(p.h), -p.h * p.d, p.A_eq, p.b_eq, p.A_in, lo, up)
            state["qp"] = qp
        else:
            qp.update(np.diag(p.h), -p.h * p.d, p.A_eq, p.b_eq, p.A_in, lo, up)
        qp.solve()
        st = qp.results.info.status
        S = proxsuite.proxqp.QPSolverOutput
        if st == S.PROXQP_SOLVED:
            return qp.results.x.copy(), SolveStatus.OPTIMAL, "", int(qp.results.info.iter)
        state.pop("qp")
        return (
            None,
            (SolveStatus.INFEASIBLE if st == S.PROXQP_PRIMAL_INFEASIBLE else SolveStatus.FAILED),
            str(st),
            0,
        )

    return solve


def make_piqp():
    import piqp

    def solve(p: QsProblem):
        s = piqp.DenseSolver()
        s.settings.eps_abs = 1e-9
        s.settings.eps_rel = 1e-12
        s.setup(
            np.asfortranarray(np.diag(p.h)),
            -p.h * p.d,
            np.asfortranarray(p.A_eq),
            p.b_eq,
            np.asfortranarray(p.A_in),
            p.lower,
            p.upper,
        )
        st = s.solve()
        if st == piqp.PIQP_SOLVED:
            return s.result.x.copy(), SolveStatus.OPTIMAL, "", int(s.result.info.iter)
        return (
            None,
            (SolveStatus.INFEASIBLE if st == piqp.PIQP_PRIMAL_INFEASIBLE else SolveStatus.FAILED),
            str(st),
            0,
        )

    return solve


def make_drake_osqp():
    """Drake's OSQP: the MathematicalProgram is built once, its coefficients updated every tick."""
    from pydrake.solvers import MathematicalProgram, OsqpSolver, SolverOptions

    solver = OsqpSolver()
    opts = SolverOptions()
    for k, v in {"eps_abs": 1e-7, "eps_rel": 1e-7, "polishing": 1, "max_iter": 20000}.items():
        opts.SetOption(solver.solver_id(), k, v)
    state = {}

    def solve(p: QsProblem):
        if "prog" not in state:
            prog = MathematicalProgram()
            x = prog.NewContinuousVariables(p.h.size)
            state["cost"] = prog.AddQuadraticCost(np.diag(p.h), -p.h * p.d, x, is_convex=True)
            state["eq"] = prog.AddLinearEqualityConstraint(p.A_eq, p.b_eq, x)
            state["in"] = prog.AddLinearConstraint(p.A_in, p.lower, p.upper, x)
            state["prog"] = prog
        else:
            state["cost"].evaluator().UpdateCoefficients(np.diag(p.h), -p.h * p.d, 0.0, is_convex=True)
            state["eq"].evaluator().UpdateCoefficients(p.A_eq, p.b_eq)
            state["in"].evaluator().UpdateCoefficients(p.A_in, p.lower, p.upper)
        r = solver.Solve(state["prog"], None, opts)
        if r.is_success():
            return r.GetSolution(), SolveStatus.OPTIMAL, "", 0
        return None, SolveStatus.FAILED, str(r.get_solution_result()), 0

    return solve


def candidates(verbose: bool = False) -> dict[str, object]:
    out: dict[str, object] = {"daqp": "daqp"}
    for name, make in (
        ("quadprog", make_quadprog),
        ("proxsuite", make_proxsuite),
        ("piqp", make_piqp),
        ("drake-osqp", make_drake_osqp),
    ):
        try:
            out[name] = make()
        except ImportError as e:
            if verbose:
                print(f"(skipped {name}: {e})")
    return out


# --------------------------------------------------------------------------- benchmark
def run(ticks: int) -> None:
    from drake_sot.generalized import generalized_projectors

    robot = Humanoid()
    tasks0, _ = robot.tasks(0)
    names = [t.name for t in tasks0]
    alpha = priority_alpha(names)
    lo, hi = -TAU_MAX, TAU_MAX
    forms = {"hierarchical eq. 9-11": False, "weighted eq. 5-7": True}
    per_form = {
        f: candidates(verbose=(f == "weighted eq. 5-7")) for f in forms
    }  # one adapter (and its warm-start state) per QP
    solvers = list(per_form["weighted eq. 5-7"])
    qps = {(s, f): QuasiStaticQP(N, N_BASE, lo, hi, solver=per_form[f][s]) for f in forms for s in solvers}
    cold = {f: QuasiStaticQP(N, N_BASE, lo, hi, warm_start=False) for f in forms}
    tick_qp = QuasiStaticQP(N, N_BASE, lo, hi)
    times: dict[tuple[str, str], list[float]] = {k: [] for k in qps}
    times.update({("daqp, cold start", f): [] for f in forms})
    fails: dict[tuple[str, str], int] = {k: 0 for k in times}
    why: dict[str, str] = {}
    err: dict[tuple[str, str], float] = {k: 0.0 for k in times}
    build, proj, full, active, dims = [], [], [], [], sum(t.jacobian.shape[0] for t in tasks0)
    for k in range(ticks):
        raw, g = robot.tasks(k)
        P = generalized_projectors([t.jacobian for t in raw], alpha)
        hier = with_projectors(raw, P)
        for form, weighted in forms.items():
            ts = raw if weighted else hier
            ref = None
            for s in solvers:
                sol = qps[(s, form)].solve(ts, g, weighted=weighted)
                times[(s, form)].append(sol.solve_time)
                if sol.status is not SolveStatus.OPTIMAL:
                    fails[(s, form)] += 1
                    why.setdefault(s, f"{sol.status.value}: {sol.message}")
                    continue
                x = np.concatenate(list(sol.wrenches.values()))
                if s == "daqp":
                    ref = x
                    prob = qps[(s, form)].build(ts, g, weighted=weighted)
                    r = np.concatenate([prob.A_in @ x - prob.upper, prob.lower - prob.A_in @ x])
                    active.append(int(np.sum(np.abs(r) < 1e-7)))
                elif ref is not None:
                    err[(s, form)] = max(err[(s, form)], float(np.abs(x - ref).max()))
            sol = cold[form].solve(ts, g, weighted=weighted)
            times[("daqp, cold start", form)].append(sol.solve_time)
            fails[("daqp, cold start", form)] += sol.status is not SolveStatus.OPTIMAL
        t0 = time.perf_counter()
        qps[("daqp", "hierarchical eq. 9-11")].build(hier, g)
        build.append(time.perf_counter() - t0)
        # Full tick: the 18 generalized projectors + QP build + solve.
        t0 = time.perf_counter()
        P = generalized_projectors([t.jacobian for t in raw], alpha)
        t1 = time.perf_counter()
        sol = tick_qp.solve(with_projectors(raw, P), g)
        full.append(time.perf_counter() - t0)
        proj.append(t1 - t0)
        assert sol.status is SolveStatus.OPTIMAL, sol.message

    def us(v):
        return f"{1e6 * v:.0f} µs"

    def p99(v):
        return float(np.percentile(v, 99))

    print(
        f"n = {N} ({N_BASE} root + {N_A} actuated), {len(tasks0)} tasks, m = {dims} variables, "
        f"{ticks} ticks; active inequalities per tick (daqp): median {statistics.median(active):.0f}, "
        f"max {max(active)}\n"
    )
    print("| measurement | median | p99 | ratio to daqp (median) | not optimal | max abs(x - x_daqp) |")
    print("|---|---|---|---|---|---|")
    for form in forms:
        base = statistics.median(times[("daqp", form)])
        for s in [*solvers, "daqp, cold start"]:
            v = times[(s, form)]
            e = "-" if s.startswith("daqp") else f"{err[(s, form)]:.1e}"
            print(
                f"| {s}, {form} | {us(statistics.median(v))} | {us(p99(v))} | "
                f"{statistics.median(v) / base:.2f} | {fails[(s, form)]}/{ticks} | {e} |"
            )
    print(
        f"| QP build alone (hierarchical) | {us(statistics.median(build))} | {us(p99(build))} | - | - | - |"
    )
    print(f"| 18 generalized projectors | {us(statistics.median(proj))} | {us(p99(proj))} | - | - | - |")
    print(
        f"| full tick: 18 projectors + build + daqp solve | {us(statistics.median(full))} "
        f"| {us(p99(full))} | - "
        f"| target: median ≤ 1000 µs, p99 ≤ 3000 µs | - |"
    )
    for s, msg in why.items():
        print(f"\nfirst non-optimal answer of {s}: {msg}")


def update_samples(duration: float = 4.0) -> tuple[list[float], object]:
    """The GeneralizedHierarchyController's whole update (measured state → kinematics,
    features, tasks, projectors, QP, torques) inside ``table_pounding`` (10 goal-directed
    tasks + 8 contact points = 18 tasks, 73 task dimensions, 36 DoF), in physics: each
    update's time [s], and the scenario's setup.

    The time is the thread's CPU time (``time.thread_time``), not the wall clock: the two trees
    compared run at the same time on two cores shared with other work, where a wall-clock
    update also counts the slices the scheduler gave to others (at a load of 10, medians of the
    same tree moved by 30 % from one pair to the next)."""
    from drake_sot.diagrams import table_pounding
    from drake_sot.diagrams.run import simulate
    from drake_sot.systems.generalized_controller import GeneralizedHierarchyController

    samples: list[float] = []
    original = GeneralizedHierarchyController._update

    def timed(self, context, state):
        t0 = time.thread_time()
        original(self, context, state)
        samples.append(time.thread_time() - t0)

    GeneralizedHierarchyController._update = timed
    try:
        setup = table_pounding.build(None)
        simulate(setup.built.create_simulator(), duration, setup.commands)
    finally:
        GeneralizedHierarchyController._update = original
    return samples, setup


#: The tree the controller update is compared with by default (``git archive``; ``--baseline``):
#: main before the torque family's pure module and its speed work of 2026-11-26. It runs with
#: ``OPENBLAS_NUM_THREADS=1``, as this tree's front-ends pin it (drake_sot.blas), so that the ratio
#: is the code's alone.
BASELINE_COMMIT = "85d3c92"
UPDATE_FLAG = "--update-median"
#: The paper's mean controller time per tick [µs] (Liu, Lober, Padois 2016, section 4.1, in C++).
PAPER_MEAN_US = 1520.0


def update_against_baseline(commit: str = BASELINE_COMMIT, pairs: int = 3) -> list[tuple[float, float]]:
    """(baseline, this tree) medians [µs] of the update in ``table_pounding``, the tree of
    ``commit`` and this one simulated at the same time in two interpreters (they share the
    machine's load), ``pairs`` times."""
    root = pathlib.Path(__file__).resolve().parent.parent
    out = []
    with tempfile.TemporaryDirectory() as baseline:
        extract(commit, pathlib.Path(baseline))
        for _ in range(pairs):
            runs = [
                subprocess.Popen(
                    [sys.executable, __file__, UPDATE_FLAG],
                    cwd=tree,
                    env={**os.environ, "PYTHONPATH": str(tree), "OPENBLAS_NUM_THREADS": "1"},
                    stdout=subprocess.PIPE,
                    text=True,
                )
                for tree in (baseline, root)
            ]
            base, tree = (float(run.communicate()[0].split()[-1]) for run in runs)
            out.append((base, tree))
    return out


def controller_tick(commit: str = BASELINE_COMMIT, pairs: int = 3, duration: float = 4.0) -> None:
    """Print the table of the controller's update (:func:`update_samples`) and its medians
    beside the tree of ``commit``'s, simulated at the same time (:func:`update_against_baseline`),
    with the paper's 1.52 ms mean (Liu, Lober, Padois 2016) as the unit of the last column."""
    samples, setup = update_samples(duration)
    us = 1e6 * np.array(samples)
    dims = sum(t.dimension for t in setup.built.tasks.values()) + 3 * 8
    print(
        f"\ncontroller update in table_pounding, CPU time ({len(setup.built.tasks)} goal tasks + 8 contacts, "
        f"m = {dims}, {len(us)} ticks in physics):\n"
    )
    print("| measurement | median | p99 | target |")
    print("|---|---|---|---|")
    print(
        f"| GeneralizedHierarchyController update | {np.median(us):.0f} µs | {np.percentile(us, 99):.0f} µs "
        f"| median ≤ 0.5 × {PAPER_MEAN_US:.0f} µs = {0.5 * PAPER_MEAN_US:.0f} µs |"
    )
    print(f"\nthe same update, this tree and commit {commit} simulated at the same time:\n")
    print("| pair | this tree (median) | baseline (median) | ratio | this tree / 1.52 ms | load average |")
    print("|---|---|---|---|---|---|")
    for k, (base, tree) in enumerate(update_against_baseline(commit, pairs), start=1):
        load = os.getloadavg()[0]
        print(
            f"| {k} | {tree:.0f} µs | {base:.0f} µs | {tree / base:.2f} | "
            f"{tree / PAPER_MEAN_US:.2f} | {load:.1f} |"
        )


def main() -> None:
    from drake_sot.blas import limit_blas_threads  # not at the top: the baseline tree has none

    limit_blas_threads(1)  # as the front-ends do when they start a run (drake_sot.blas)
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ticks", type=int, default=500)
    ap.add_argument(
        "--baseline", default=BASELINE_COMMIT, help="commit the controller update is compared with"
    )
    ap.add_argument("--pairs", type=int, default=3, help="same-time runs of this tree and the baseline")
    ap.add_argument("--update-only", action="store_true", help="only the controller update's tables")
    args = ap.parse_args()
    if not args.update_only:
        run(args.ticks)
    controller_tick(args.baseline, args.pairs)


if __name__ == "__main__":
    if sys.argv[1:] == [UPDATE_FLAG]:
        print(f"{1e6 * statistics.median(update_samples()[0]):.1f}")
    else:
        main()
