"""Peer benchmark: ``drake_sot.hqp.solve_hqp`` against PlaCo's ``KinematicsSolver`` on TALOS.

    make bench-peers      (creates .venv-peers with placo, pin and example-robot-data, then runs this)

PlaCo (Rhoban, PyPI ``placo`` 0.10.2) pins ``pin`` 3.8 and ``numpy`` 2.3, so it lives in its own
virtual environment and is no dependency of the package; this file needs ``placo``, ``pinocchio``
(installed with placo) and ``example-robot-data`` (6.0.0), and finds ``drake_sot`` on the path. It
imports no pydrake: the hierarchy module is pure, and TALOS comes from the pure catalog of
``drake_sot.robots`` (the robot the scenarios and ``bench_robots.py`` simulate).

The problem (TALOS as ``drake_sot.robots.catalog.talos()`` describes it: ``talos_full_v2.urdf``
from example-robot-data with the robot layer's in-memory fixes (package map, ``package:///``
typos, the gripper linkage frozen, no geometry), the half-sitting of its SRDF by joint name;
nv = 36, 30 actuated joints), the same for both sides and solved call by call in one process:

    left foot 6D, right foot 6D, CoM 3D, right hand 6D, left hand 3D, head orientation 3D,
    posture 30D                                         (7 levels, 57 rows)

under the joint position limits (``q + dt q̇`` inside them) and velocity limits of the URDF
(60 inequality rows on the 30 actuated joints), for a 2 s trajectory at dt = 5 ms: the CoM sways
3 cm sideways, the right hand reaches 0.40 m forward and 0.20 m up, the left hand moves 0.15 m,
the head turns 0.4 rad. Each side integrates its own q.

- **drake_sot**: the Jacobians and task errors from Pinocchio (the same library and the same
  URDF text PlaCo loads, so the two sides start from the same task matrices to rounding, checked;
  Drake kinematics would make the comparison also measure two kinematics libraries), each level
  ``J q̇ = e / dt``,
  under a top level of the 30 joint-limit rows ``velocity_bounds(q, q_min, q_max, 1/dt, ±v_max)``,
  solved by ``solve_hqp`` (strict priorities), warm-started from the last step's result (as
  ``StackOfTasks`` does from tick to tick). Timed separately: "kinematics" (Pinocchio's
  Jacobians, frame placements, CoM Jacobian, errors, and the integration of q) and "solve".
- **PlaCo**: the same tasks in one weighted QP (PlaCo has no strict hierarchy): feet "hard"
  (equality constraints), the others "soft" (:data:`PLACO_WEIGHTED`), joint and velocity limits
  enabled. Timed: ``robot.update_kinematics()`` (frames and joint Jacobians, in C++) and
  ``solver.solve(True)`` (each task's Jacobian and error, the QP, the integration). The two sides
  do not cut kinematics and solve at the same place, so the whole steps are the comparison.

Beside them on the same levels at the same state: ``solve_hqp`` cold (no warm start), without the
limit level, and ``solve_strict``. The ratios are medians of per-step ratios (both timed in the
same step, their order alternating from step to step).

Agreement printed: (1) the task matrices and errors of the two sides at the start; (2) with the
six upper task levels "hard" in PlaCo and the posture "soft" (no limits), PlaCo's step equals
``solve_strict``'s q̇ dt (both are then the lexicographic solution) at states along the trajectory;
(3) the task errors of the two closed-loop runs, and the joint limits, step by step.
"""

from __future__ import annotations

import os

# PlaCo (Eigen) runs on one thread; so does numpy's BLAS here (2 shared cores).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import dataclasses
import datetime
import pathlib
import platform
import statistics
import sys
import time
from collections.abc import Callable
from functools import partial
from importlib.metadata import version

import numpy as np

from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import HqpResult, solve_hqp
from drake_sot.inequalities import velocity_bounds
from drake_sot.robots.catalog import RobotDataMissing
from drake_sot.robots.catalog import talos as talos_description
from drake_sot.robots.urdf import prepare_urdf

DT = 0.005  #: control period [s]
DURATION = 2.0  #: trajectory length [s]
FRAMES = {
    "left_foot": "left_sole_link",
    "right_foot": "right_sole_link",
    "right_hand": "gripper_right_base_link",
    "left_hand": "gripper_left_base_link",
    "head": "head_2_link",
}
#: The stack, highest priority first: (name, kind) with kind "frame" (6D), "com", "position",
#: "orientation" or "posture".
STACK = (
    ("left_foot", "frame"),
    ("right_foot", "frame"),
    ("com", "com"),
    ("right_hand", "frame"),
    ("left_hand", "position"),
    ("head", "orientation"),
    ("posture", "posture"),
)
#: PlaCo's priorities for the same stack, (priority, weight) per task: the feet hard, the others
#: soft by decades, and the posture (which cannot be met while the hands reach away) light enough
#: not to pull the tasks above it: weighted 1, it leaves the left hand 4 cm off at the end of the run.
PLACO_WEIGHTED = {
    "left_foot": ("hard", 1.0),
    "right_foot": ("hard", 1.0),
    "com": ("soft", 1e4),
    "right_hand": ("soft", 1e3),
    "left_hand": ("soft", 1e2),
    "head": ("soft", 1e1),
    "posture": ("soft", 1e-4),
}
#: The six upper tasks hard and the posture soft: with no limits, PlaCo's QP is then the
#: lexicographic problem of ``solve_strict`` (its small fixed regularisation aside, which is why
#: the posture keeps weight 1 here).
PLACO_STRICT = {name: ("hard", 1.0) for name, _ in STACK} | {"posture": ("soft", 1.0)}


def talos_model() -> tuple[pathlib.Path, str, dict[str, float]]:
    """TALOS as ``drake_sot.robots`` describes it (its pure catalog: no pydrake): the model file,
    the URDF text with the robot layer's fixes and without geometry, and the half-sitting angle
    [rad] of every moving joint (from the SRDF)."""
    try:
        robot = talos_description()
    except RobotDataMissing as error:
        raise SystemExit(f"{error}; or run `make bench-peers`") from error
    text, _ = prepare_urdf(
        robot.model_file.read_text(),
        packages=robot.packages,
        mesh_file=None,
        frozen_joints=robot.frozen_joints,
        added_welds=robot.added_welds,
    )
    return robot.model_file, text, dict(robot.half_sitting)


@dataclasses.dataclass
class Targets:
    """The set points of every task at one time."""

    poses: dict[str, np.ndarray]  # 4x4 world poses of the feet and the right hand
    left_hand: np.ndarray  # (3,)
    head: np.ndarray  # 3x3
    com: np.ndarray  # (3,)
    posture: np.ndarray  # (30,) actuated joint positions


def trajectory(start: Targets, t: float) -> Targets:
    """The targets at time ``t``: from ``start`` (the half-sitting's values), a smooth reach."""
    s = 0.5 * (1.0 - np.cos(np.pi * min(t / 1.5, 1.0)))  # 0 -> 1 over 1.5 s, then held
    poses = {name: pose.copy() for name, pose in start.poses.items()}
    poses["right_hand"][:3, 3] += s * np.array([0.40, -0.05, 0.20])
    yaw = 0.4 * s
    rz = np.array([[np.cos(yaw), -np.sin(yaw), 0.0], [np.sin(yaw), np.cos(yaw), 0.0], [0.0, 0.0, 1.0]])
    return Targets(
        poses=poses,
        left_hand=start.left_hand + s * np.array([0.15, 0.05, 0.10]),
        head=rz @ start.head,
        com=start.com + np.array([0.0, 0.03 * np.sin(np.pi * t), 0.0]),
        posture=start.posture,
    )


class Talos:
    """TALOS in Pinocchio, for the drake_sot side: task Jacobians and errors at q."""

    def __init__(self, pin, urdf_text: str, half_sitting: dict[str, float]):
        self.pin = pin
        self.model = pin.buildModelFromXML(urdf_text, pin.JointModelFreeFlyer())
        self.data = self.model.createData()
        self.q0 = pin.neutral(self.model)  # the base at the origin, upright
        for name, angle in half_sitting.items():
            self.q0[self.model.joints[self.model.getJointId(name)].idx_q] = angle
        self.frame_ids = {name: self.model.getFrameId(frame) for name, frame in FRAMES.items()}
        self.nv = self.model.nv
        self.joint_names = [self.model.names[i] for i in range(2, self.model.njoints)]
        self.q_min = self.model.lowerPositionLimit[7:].copy()
        self.q_max = self.model.upperPositionLimit[7:].copy()
        self.v_max = self.model.velocityLimit[6:].copy()
        self.posture_J = np.eye(self.nv)[6:]

    def targets_at(self, q: np.ndarray) -> Targets:
        """The task values at ``q`` (the trajectory's start)."""
        pin, data = self.pin, self.data
        pin.forwardKinematics(self.model, data, q)
        pin.updateFramePlacements(self.model, data)
        pose = {name: data.oMf[self.frame_ids[name]].homogeneous.copy() for name in FRAMES}
        return Targets(
            poses={name: pose[name] for name in ("left_foot", "right_foot", "right_hand")},
            left_hand=pose["left_hand"][:3, 3].copy(),
            head=pose["head"][:3, :3].copy(),
            com=pin.centerOfMass(self.model, data, q).copy(),
            posture=q[7:].copy(),
        )

    def tasks(self, q: np.ndarray, targets: Targets) -> list[tuple[np.ndarray, np.ndarray]]:
        """Per level of :data:`STACK`, ``(J, e)`` with ``J Δq = e`` the step that closes the error:
        Jacobians in the world-aligned frame at the body (rows linear then angular, as PlaCo's),
        position errors ``p* - p``, orientation errors ``log(R* Rᵀ)``, CoM and posture ``x* - x``."""
        pin, model, data = self.pin, self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        jcom = pin.jacobianCenterOfMass(model, data, True)
        out = []
        for name, kind in STACK:
            if kind == "com":
                out.append((jcom, targets.com - data.com[0]))
                continue
            if kind == "posture":
                out.append((self.posture_J, targets.posture - q[7:]))
                continue
            fid = self.frame_ids[name]
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            placement = data.oMf[fid]
            if kind == "frame":
                target = targets.poses[name]
                e_pos = target[:3, 3] - placement.translation
                e_rot = pin.log3(target[:3, :3] @ placement.rotation.T)
                out.append((J, np.concatenate([e_pos, e_rot])))
            elif kind == "position":
                out.append((J[:3], targets.left_hand - placement.translation))
            else:
                out.append((J[3:], pin.log3(targets.head @ placement.rotation.T)))
        return out

    def limit_level(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``lower <= q̇_joints <= upper``: ``q + dt q̇`` inside the position limits, ``|q̇| <= v_max``."""
        lower, upper = velocity_bounds(q[7:], self.q_min, self.q_max, 1.0 / DT, -self.v_max, self.v_max)
        return self.posture_J, lower, upper


def stack_levels(
    tasks: list[tuple[np.ndarray, np.ndarray]],
    limits: tuple[np.ndarray, np.ndarray, np.ndarray] | None,
) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """The levels of ``solve_hqp`` in velocity units: ``J q̇ = e / dt`` per task (each task closes its
    error in one period, PlaCo's unit gain), under ``limits`` when given; each as ``StackOfTasks``
    passes an equality task, ``(J, target, target)`` with the same array twice."""
    levels = [(J, target, target) for J, target in ((J, e / DT) for J, e in tasks)]
    return levels if limits is None else [limits, *levels]


class Placo:
    """PlaCo's KinematicsSolver on its own RobotWrapper, holding the same stack."""

    def __init__(
        self,
        placo,
        urdf: pathlib.Path,
        urdf_text: str,
        q0: np.ndarray,
        priorities: dict[str, tuple[str, float]],
        *,
        limits: bool,
    ):
        self.robot = placo.RobotWrapper(str(urdf), placo.Flags.ignore_collisions, urdf_text)
        self.robot.state.q = q0.copy()
        self.robot.update_kinematics()
        self.solver = placo.KinematicsSolver(self.robot)
        self.solver.mask_fbase(False)
        self.solver.dt = DT
        self.solver.enable_joint_limits(limits)
        self.solver.enable_velocity_limits(limits)
        self.tasks = {}
        eye = np.eye(4)
        for name, kind in STACK:
            if kind == "frame":
                task = self.solver.add_frame_task(FRAMES[name], eye)
            elif kind == "com":
                task = self.solver.add_com_task(np.zeros(3))
            elif kind == "position":
                task = self.solver.add_position_task(FRAMES[name], np.zeros(3))
            elif kind == "orientation":
                task = self.solver.add_orientation_task(FRAMES[name], np.eye(3))
            else:
                task = self.solver.add_joints_task()
            priority, weight = priorities[name]
            task.configure(name, priority, *((weight, weight) if kind == "frame" else (weight,)))
            self.tasks[name] = task
        self.joint_names = list(self.robot.joint_names())

    def set_targets(self, targets: Targets) -> None:
        for name in ("left_foot", "right_foot", "right_hand"):
            self.tasks[name].T_world_frame = targets.poses[name]
        self.tasks["com"].target_world = targets.com
        self.tasks["left_hand"].target_world = targets.left_hand
        self.tasks["head"].R_world_frame = targets.head
        self.tasks["posture"].set_joints(dict(zip(self.joint_names, targets.posture, strict=True)))

    def matrices(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """PlaCo's ``(A, b)`` per level of :data:`STACK` after its last solve (``A Δq = b``)."""
        out = []
        for name, kind in STACK:
            task = self.tasks[name]
            if kind == "frame":
                parts = (task.position(), task.orientation())
                out.append((np.vstack([p.A for p in parts]), np.concatenate([p.b.ravel() for p in parts])))
            elif kind == "posture":  # one row per joint, in the order of the joint names: sort by column
                order = np.argsort(np.argmax(np.abs(task.A), axis=1))
                out.append((task.A[order], task.b.ravel()[order]))
            else:
                out.append((task.A, task.b.ravel()))
        return out


def _time(fn: Callable[..., object], *args: object) -> tuple[float, object]:
    t0 = time.perf_counter()
    value = fn(*args)
    return time.perf_counter() - t0, value


@dataclasses.dataclass
class Step:
    """One timed step of the drake_sot side."""

    kinematics: float  # [s]: task Jacobians and errors, limit bounds, integration
    solve: float  # [s]: solve_hqp
    tasks: list[tuple[np.ndarray, np.ndarray]]
    levels: list[tuple[np.ndarray, np.ndarray, np.ndarray]]  # the limit level first
    result: HqpResult
    q_next: np.ndarray


def drake_sot_step(pin, talos: Talos, q: np.ndarray, target: Targets, previous: HqpResult | None) -> Step:
    """One step of the drake_sot controller, warm-started from its last step's result ``previous``
    (None at the first step), as ``StackOfTasks`` does from tick to tick."""
    t_kin, tasks = _time(talos.tasks, q, target)
    t_lim, limits = _time(talos.limit_level, q)
    levels = stack_levels(tasks, limits)
    t_hqp, result = _time(partial(solve_hqp, validate=False, warm_start=previous), levels)
    t_int, q_next = _time(pin.integrate, talos.model, q, result.qdot * DT)
    return Step(t_kin + t_lim + t_int, t_hqp, tasks, levels, result, q_next)


def placo_step(peer: Placo) -> tuple[float, float]:
    """PlaCo's step, timed: ``(update_kinematics, solve(True))`` [s]."""
    t_kin, _ = _time(peer.robot.update_kinematics)
    t_solve, _ = _time(peer.solver.solve, True)
    return t_kin, t_solve


def run(passes: int) -> dict:
    import pinocchio as pin
    import placo

    urdf, urdf_text, half_sitting = talos_model()
    talos = Talos(pin, urdf_text, half_sitting)
    assert sorted(talos.joint_names) == sorted(half_sitting), "the description and Pinocchio differ"
    steps = round(DURATION / DT)
    start = talos.targets_at(talos.q0)
    targets = [trajectory(start, k * DT) for k in range(steps)]
    peer = Placo(placo, urdf, urdf_text, talos.q0, PLACO_WEIGHTED, limits=True)
    checker = Placo(placo, urdf, urdf_text, talos.q0, PLACO_STRICT, limits=False)
    assert peer.joint_names == talos.joint_names, "PlaCo and Pinocchio order the joints differently"

    # (1) The same task matrices at the start.
    peer.set_targets(targets[0])
    peer.solver.solve(False)
    matrix_gap = max(
        max(np.abs(J - A).max(), np.abs(e - b).max())
        for (J, e), (A, b) in zip(talos.tasks(talos.q0, targets[0]), peer.matrices(), strict=True)
    )

    names = ("placo_kin", "placo_solve", "kin", "hqp", "hqp_cold", "hqp_free", "strict")
    times: dict[str, list[float]] = {name: [] for name in names}
    errors = {"hqp": np.zeros((steps, len(STACK))), "placo": np.zeros((steps, len(STACK)))}
    excess = {"hqp": 0.0, "placo": 0.0}
    limit_steps = binding_steps = 0
    q_gap = 0.0
    iterations: list[int] = []
    cold_iterations: list[int] = []
    limited_joints: set[str] = set()
    strict_gap = hqp_gap = warm_gap = 0.0
    for p in range(passes):
        q = talos.q0.copy()
        peer.robot.state.q = talos.q0.copy()
        last: HqpResult | None = None  # the controller's last result: its warm start
        for k, target in enumerate(targets):
            peer.set_targets(target)
            if k % 2:  # alternate which side runs first
                placo_kin, placo_solve = placo_step(peer)
                ours = drake_sot_step(pin, talos, q, target, last)
            else:
                ours = drake_sot_step(pin, talos, q, target, last)
                placo_kin, placo_solve = placo_step(peer)
            free = ours.levels[1:]
            pairs = [(J, e) for J, e, _ in free]
            sample = (
                placo_kin,
                placo_solve,
                ours.kinematics,
                ours.solve,
                _time(partial(solve_hqp, validate=False), ours.levels)[0],
                _time(partial(solve_hqp, validate=False), free)[0],
                _time(partial(solve_strict, validate=False), pairs)[0],
            )
            for name, value in zip(names, sample, strict=True):
                times[name].append(value)
            if p == 0:
                errors["hqp"][k] = [np.linalg.norm(e) for _, e in ours.tasks]
                errors["placo"][k] = [np.linalg.norm(b) for _, b in peer.matrices()]
                limits = ours.result.levels[0]
                active = limits.active_lower + limits.active_upper
                limit_steps += bool(active)
                limited_joints.update(talos.joint_names[i] for i in active)
                iterations.append(ours.result.iterations)
                cold = solve_hqp(ours.levels)
                cold_iterations.append(cold.iterations)
                warm_gap = max(warm_gap, np.abs(ours.result.qdot - cold.qdot).max())
                # a limit binds when q̇ differs from the same levels' solution without limits
                binding_steps += bool(np.abs(ours.result.qdot - solve_hqp(free).qdot).max() > 1e-9)
                if k % 20 == 0:  # (2) PlaCo with hard upper levels equals solve_strict
                    checker.robot.state.q = q.copy()
                    checker.robot.update_kinematics()
                    checker.set_targets(target)
                    strict = solve_strict(pairs).qdot
                    strict_gap = max(strict_gap, np.abs(checker.solver.solve(False) - strict * DT).max())
                    hqp_gap = max(hqp_gap, np.abs(solve_hqp(free).qdot - strict).max())
            q, last = ours.q_next, ours.result
            if p == 0:
                q_gap = max(q_gap, np.abs(q - peer.robot.state.q).max())
            for side, qs in (("hqp", q), ("placo", peer.robot.state.q)):
                over = np.maximum(qs[7:] - talos.q_max, talos.q_min - qs[7:]).max()
                excess[side] = max(excess[side], over)
    return {
        "times": times,
        "errors": errors,
        "excess": excess,
        "limit_steps": limit_steps,
        "binding_steps": binding_steps,
        "q_gap": q_gap,
        "matrix_gap": matrix_gap,
        "strict_gap": strict_gap,
        "hqp_gap": hqp_gap,
        "iterations": iterations,
        "cold_iterations": cold_iterations,
        "warm_gap": warm_gap,
        "limited_joints": limited_joints,
        "steps": steps,
        "passes": passes,
        "nv": talos.nv,
        "rows": sum(J.shape[0] for J, _ in talos.tasks(talos.q0, targets[0])),
    }


def _median_ratio(a: list[float], b: list[float]) -> float:
    return statistics.median(x / y for x, y in zip(a, b, strict=True))


def report(out: dict) -> str:
    t = out["times"]
    ours = [k + s for k, s in zip(t["kin"], t["hqp"], strict=True)]
    placo_step = [k + s for k, s in zip(t["placo_kin"], t["placo_solve"], strict=True)]
    us = {name: 1e6 * statistics.median(v) for name, v in t.items()}
    pairs = len(ours)
    step = 1e6 * statistics.median(placo_step)

    def row(label: str, samples: list[float], part: list[float] | None) -> str:
        median = 1e6 * statistics.median(samples)
        ratio = "-" if part is None else f"{_median_ratio(samples, part):.2f}"
        return f"| {label} | {median:.0f} µs | {_median_ratio(samples, placo_step):.2f} | {ratio} |"

    iterations = out["iterations"]
    actuated = out["nv"] - 6
    lines = [
        f"TALOS talos_full_v2, grippers frozen (drake_sot.robots; nv = {out['nv']}), {len(STACK)} task "
        f"levels ({out['rows']} rows) + {actuated} joint-limit rows, "
        f"{out['steps']} steps of {1e3 * DT:g} ms x {out['passes']} passes = {pairs} interleaved pairs; "
        f"placo {version('placo')}, pin {version('pin')}, numpy {np.__version__}, Python "
        f"{platform.python_version()}, {datetime.date.today()}",
        "",
        "| measurement | median | ÷ PlaCo step | ÷ PlaCo's part |",
        "|---|---|---|---|",
        f"| PlaCo step: update_kinematics + solve(True), {2 * actuated} limit rows | {step:.0f} µs | 1 | - |",
        f"| - update_kinematics (frames, joint Jacobians) | {us['placo_kin']:.0f} µs | - | 1 |",
        f"| - solve(True) (task Jacobians, errors, QP, integration) | {us['placo_solve']:.0f} µs | - | 1 |",
        row("drake_sot step: kinematics + solve_hqp with limits", ours, None),
        row("- kinematics (Pinocchio, task errors, limit bounds, integration)", t["kin"], t["placo_kin"]),
        row(f"- solve_hqp, {actuated} limit rows above the 7 levels, warm", t["hqp"], t["placo_solve"]),
        row(f"solve_hqp, {actuated} limit rows above the 7 levels, cold", t["hqp_cold"], t["placo_solve"]),
        row("solve_hqp, the 7 levels without limits", t["hqp_free"], t["placo_solve"]),
        row("solve_strict, the 7 levels", t["strict"], t["placo_solve"]),
        "",
        f"solve_hqp with limits: {statistics.median(iterations):.0f} active-set iterations per step "
        f"warm (median; max {max(iterations)}), {statistics.median(out['cold_iterations']):.0f} cold "
        f"(max {max(out['cold_iterations'])}); a joint is at a limit in {out['limit_steps']} of "
        f"{out['steps']} steps ({', '.join(sorted(out['limited_joints']))}), and the limits change q̇ "
        f"in {out['binding_steps']} of them.",
        "",
        "Agreement:",
        f"- task matrices and errors at the start, drake_sot (Pinocchio) vs PlaCo: max |diff| "
        f"{out['matrix_gap']:.1e}",
        f"- PlaCo with the six upper tasks hard and the posture soft, no limits, vs solve_strict "
        f"(q̇ dt) at every 20th state of the run: max |Δq diff| {out['strict_gap']:.1e} rad; "
        f"solve_hqp without limits vs solve_strict there: max |q̇ diff| {out['hqp_gap']:.1e} rad/s",
        f"- solve_hqp with limits, warm-started vs cold, every step: max |q̇ diff| "
        f"{out['warm_gap']:.1e} rad/s",
        f"- joint limits: largest excursion past a position limit, drake_sot {out['excess']['hqp']:.1e} rad, "
        f"PlaCo {out['excess']['placo']:.1e} rad; largest gap between the two runs' joint positions "
        f"{out['q_gap']:.1e} rad",
        "",
        "Task error norms in the closed-loop runs (each side on its own q), drake_sot / PlaCo:",
        "",
        "| task | mean | at 1.0 s | at the end |",
        "|---|---|---|---|",
    ]
    mid = out["steps"] // 2
    for i, (name, _) in enumerate(STACK):
        h, p = out["errors"]["hqp"][:, i], out["errors"]["placo"][:, i]
        lines.append(
            f"| {name} | {h.mean():.1e} / {p.mean():.1e} | {h[mid]:.1e} / {p[mid]:.1e} "
            f"| {h[-1]:.1e} / {p[-1]:.1e} |"
        )
    return "\n".join(lines)


def main() -> None:
    passes = int(sys.argv[1]) if len(sys.argv) > 1 else 5
    print(report(run(passes)))


if __name__ == "__main__":
    main()
