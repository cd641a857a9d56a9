"""The measuring side of the studies: each run target, what it declares, and :func:`measure`, the
function a Dask worker calls with a run's names and numbers (see :mod:`drake_sot.studies.runner`).

A target is a scenario run without a Meshcat: ``walk`` and ``reach`` with a pelvis push given
as numbers (:data:`PUSH`), ``reach`` also with the gain of its right-hand task
(:data:`RH_GAIN`), ``priority_switching`` with constant priorities (Liu, Lober, Padois
2016, fig. 11), and ``telecooperation_standing``: the tele-cooperation of Evrard et al. 2009
standing (the leader lifts the board by 5 cm from 1 s and sets it back, ``walk=False``) over
its link's one-way delay, jitter and loss, the link's packets drawn from the run's seed. Every
run measures:

- ``survived``: the robot did not fall (no :class:`~drake_sot.systems.fall_monitor.FallMonitor`
  saw it) in the run's duration;
- ``fall_time`` [s]: when it fell, NaN when it did not;
- ``min_pelvis_height`` [m]: the lowest height of the floating base (the pelvis), NaN on a fixed base;
- ``max_final_error_m`` [m] and ``max_final_error_rad`` [rad]: the largest norm of the
  components of a task's error at the run's end in that unit (a 6D task's position, its
  orientation; the units each feature gives, ``Feature.units``), over the tasks in the stack
  then (NaN when none has such components; the torque controller's tasks, which say no units,
  count in neither);
- ``final_error/<task>``: the norm of each task's whole error at the run's end (its units mixed
  when it has several);

``priority_switching`` also ``steady_error_head`` and ``steady_error_lh`` [m], the mean
error norm of the head and left-hand tasks over the run's last second, and ``reach`` also
``rh_settle_time`` [s], how long after its target moves the right hand's error norm takes to
stay below :data:`SETTLED` (NaN when it is not by the run's end). ``telecooperation_standing``
adds, from the leader's first move (``interact_at``, 1 s) to the run's end, both hands together
(NaN when the run ends before):

- ``tracking_error_rms``, ``tracking_error_max`` [m]: the RMS and the largest distance between
  a robot hand and the operator's hand on its handle (``MasterSite.hands``, x_S + x_Δ of
  eq. 9: where the operator commands the robot's hand to be);
- ``force_error_rms`` [N]: the RMS norm of the difference between the force the operator
  applies on a handle and the force the robot's hand applies on the board (the opposite of the
  external force its wrist sensor measures): 0 for a transparent link;
- ``force_ratio``: the RMS norm of the operator's forces over that of the robot hands' (1: the
  operator feels the whole force at the robot's hands).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from drake_sot.diagrams import priority_switching as ps
from drake_sot.diagrams import reach, walk
from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.artifacts import log_arrays
from drake_sot.diagrams.pushes import MAX_PUSH_FORCE, ExternalPush, check_push_times
from drake_sot.diagrams.run import MAX_DURATION, RunResult, TimedCommand, simulate
from drake_sot.diagrams.scenario import ROBOT, Scenario, ScenarioSetup, build_scenario
from drake_sot.errors import UnknownNameError
from drake_sot.parameters import Parameter, check_parameters
from drake_sot.studies.description import Metrics
from drake_sot.systems.inequalities import InequalityTask
from drake_sot.systems.task import Task
from drake_sot.transitions import AlphaSchedule

#: A pelvis push given as numbers: when, which way, how hard, how long (no push at 0 N).
PUSH = (
    Parameter(
        "push_time", "float", 2.0, "when the pelvis push starts", minimum=0.0, maximum=MAX_DURATION, unit="s"
    ),
    Parameter(
        "push_direction",
        "float",
        0.0,
        "the push's horizontal direction, from the x axis (forward) towards y (left)",
        minimum=-360.0,
        maximum=360.0,
        unit="deg",
    ),
    Parameter(
        "push_force",
        "float",
        0.0,
        "the push's force (0: none)",
        minimum=0.0,
        maximum=MAX_PUSH_FORCE,
        unit="N",
    ),
    Parameter("push_duration", "float", 0.1, "how long the push lasts", minimum=0.01, maximum=1.0, unit="s"),
)
#: The constant priorities of ``priority_switching`` in a study (Liu, Lober, Padois 2016, fig. 11).
ALPHAS = (
    Parameter(
        "alpha_lh_head", "float", 0.0, "α_lh,head (1: the head above the left hand)", minimum=0.0, maximum=1.0
    ),
    Parameter(
        "alpha_head_lh", "float", 1.0, "α_head,lh (1: the left hand above the head)", minimum=0.0, maximum=1.0
    ),
)

#: λ of ``reach``'s right-hand task [1/s] (its own is the default); λ·dt above 1 is refused by
#: the task at the run's start (a failed run naming it).
RH_GAIN = Parameter(
    "rh_gain", "float", 2.5, "λ of reach's right-hand task taskRH", minimum=0.1, maximum=100.0, unit="1/s"
)
#: The right hand's error norm [m] under which ``reach`` counts it settled.
SETTLED = 0.01


@dataclass(frozen=True)
class Target:
    """What a study can run: its parameters, how a run is built from their values, its
    duration [s] and its seed (what a target that draws random numbers draws them from), and
    the metrics it adds to the common ones (from the setup, the logs and the duration)."""

    parameters: tuple[Parameter, ...]
    build: Callable[[dict[str, Any], float, int], ScenarioSetup]
    extra: Callable[[ScenarioSetup, dict[str, np.ndarray], float], Metrics] | None = None


def _pushed(scenario: Scenario) -> Callable[[dict[str, Any], float], ScenarioSetup]:
    """The build of ``scenario`` with its own parameters and a pelvis push from :data:`PUSH`'s
    (raises ValueError for a push that starts at or after the run's end)."""
    own = {p.name for p in scenario.parameters}

    def build(parameters: dict[str, Any], duration: float, seed: int) -> ScenarioSetup:
        force = parameters.get("push_force", 0.0)
        pushes = ()
        if force > 0:
            angle = math.radians(parameters.get("push_direction", 0.0))
            pushes = (
                ExternalPush(
                    parameters.get("push_time", 2.0),
                    "pelvis",
                    (force * math.cos(angle), force * math.sin(angle), 0.0),
                    parameters.get("push_duration", 0.1),
                ),
            )
            check_push_times(pushes, duration)
        chosen = {k: v for k, v in parameters.items() if k in own}
        return build_scenario(scenario, None, parameters=chosen, pushes=pushes)

    return build


def _constant_priorities(parameters: dict[str, Any], duration: float, seed: int) -> ScenarioSetup:
    alpha = ps.initial_alpha(parameters.get("alpha_lh_head", 0.0), parameters.get("alpha_head_lh", 1.0))
    schedule = AlphaSchedule(list(ps.TASKS), alpha)
    return ps.build_with(schedule, duration=duration, robot=parameters.get("robot", "embedded"))


#: The label of the command that sets the right hand's gain in a ``reach`` run.
GAIN_COMMAND = "taskRH gain"


def _reach_with_gain(parameters: dict[str, Any], duration: float, seed: int) -> ScenarioSetup:
    """``reach`` pushed as :data:`PUSH` says, its right-hand task's λ set to ``rh_gain`` at t = 0
    (a command labelled :data:`GAIN_COMMAND`) when given."""
    setup = _pushed(reach.SCENARIO)(parameters, duration, seed)
    if "rh_gain" in parameters:
        task, gain = setup.built.tasks["taskRH"], parameters["rh_gain"]
        setup.commands.insert(
            0, TimedCommand(0.0, f"{GAIN_COMMAND} {gain:g}", lambda c: task.set_gain(c, gain))
        )
    return setup


def _settling(setup: ScenarioSetup, arrays: dict[str, np.ndarray], duration: float) -> Metrics:
    """``rh_settle_time``: from the target's move to the first sample from which the right
    hand's error norm stays below :data:`SETTLED` [s]; NaN when it is not below at the end."""
    own = [c for c in setup.commands if not c.label.startswith(GAIN_COMMAND)]
    moved_at = own[0].time  # reach's first command moves the right-hand target
    after = arrays["time"] >= moved_at
    time, error = arrays["time"][after], np.linalg.norm(arrays["error/taskRH"][after], axis=1)
    if not len(error) or not (error[-1] < SETTLED):
        return {"rh_settle_time": math.nan}
    unsettled = np.flatnonzero(~(error < SETTLED))
    return {"rh_settle_time": float(time[unsettled[-1] + 1] - moved_at) if len(unsettled) else 0.0}


def _steady_errors(setup: ScenarioSetup, arrays: dict[str, np.ndarray], duration: float) -> Metrics:
    """The mean head and left-hand error norms [m] over the last second."""
    window = arrays["time"] >= duration - 1.0
    return {
        f"steady_error_{key}": float(np.mean(np.linalg.norm(arrays[f"error/{task}"][window], axis=1)))
        for key, task in (("head", "taskHead"), ("lh", "taskLH"))
    }


#: The metrics ``telecooperation_standing`` adds, in the order of :func:`_transparency`.
TRANSPARENCY = ("tracking_error_rms", "tracking_error_max", "force_error_rms", "force_ratio")


def _telecooperation_standing(parameters: dict[str, Any], duration: float, seed: int) -> ScenarioSetup:
    """``telecooperation`` standing (``walk=False``), its link's packets drawn from ``seed``
    (raises ValueError for a delay and a jitter whose sum is over the link's ``MAX_DELAY``)."""
    return tc.build(None, walk=False, seed=seed, **parameters)


def _transparency(setup: ScenarioSetup, arrays: dict[str, np.ndarray], duration: float) -> Metrics:
    """The tracking and force-transparency metrics of ``telecooperation_standing`` (see the
    module's docstring), both hands, from the leader's first move on."""
    window = arrays["time"] >= tc.DEFAULT_CONFIG.interact_at
    if not window.any():
        return dict.fromkeys(TRANSPARENCY, math.nan)
    hands = [slice(0, 3), slice(3, 6)]  # [right; left]
    robot, operator = arrays["robot_hands"][window], arrays["operator_hands"][window]
    distance = np.concatenate([np.linalg.norm(robot[:, h] - operator[:, h], axis=1) for h in hands])
    felt = arrays["operator_forces"][window]
    applied = -np.hstack([arrays[f"wrench/{task}"][window, 3:] for task in tc.HAND_TASKS])
    force_error = np.concatenate([np.linalg.norm(felt[:, h] - applied[:, h], axis=1) for h in hands])
    return {
        "tracking_error_rms": float(np.sqrt(np.mean(distance**2))),
        "tracking_error_max": float(distance.max()),
        "force_error_rms": float(np.sqrt(np.mean(force_error**2))),
        "force_ratio": float(np.sqrt(np.sum(felt**2) / np.sum(applied**2))),
    }


#: The run targets of the studies, by name.
TARGETS: dict[str, Target] = {
    "walk": Target((*walk.SCENARIO.parameters, *PUSH), _pushed(walk.SCENARIO)),
    "reach": Target((*reach.SCENARIO.parameters, *PUSH, RH_GAIN), _reach_with_gain, _settling),
    "priority_switching": Target((ROBOT, *ALPHAS), _constant_priorities, _steady_errors),
    "telecooperation_standing": Target(
        (tc.LEADER, tc.DELAY, tc.JITTER, tc.LOSS, tc.ADMITTANCE), _telecooperation_standing, _transparency
    ),
}


def measure(target: str, parameters: dict[str, Any], duration: float, seed: int) -> Metrics:
    """Build and simulate one run of ``target`` (a key of :data:`TARGETS`) with ``parameters``
    for ``duration`` [s] in this process; its metrics (see the module's docstring). ``seed`` is
    the run's seed, for a target that draws random numbers (``telecooperation_standing``: its
    link's jitter and loss; the others draw none).

    Raises:
        KeyError: an unknown target (naming the known ones).
        ValueError: a parameter the target does not declare or refuses, a push after the end,
            a link's delay and jitter whose sum is over its ``MAX_DELAY``.
        RuntimeError: the run failed (an exception in the simulation), naming when and why.
    """
    if target not in TARGETS:
        raise UnknownNameError("study target", target, TARGETS)
    chosen = TARGETS[target]
    parameters = check_parameters(target, chosen.parameters, parameters)
    setup = chosen.build(parameters, duration, seed)
    simulator = setup.built.create_simulator()
    result = simulate(simulator, duration, setup.commands, check=False)
    if result.failure is not None:
        raise RuntimeError(f"{target} failed at t = {result.end_time:.3f} s: {result.failure}")
    arrays = log_arrays(setup.built, simulator.get_context(), result)
    metrics = common_metrics(setup, arrays, result)
    if chosen.extra is not None:
        metrics |= chosen.extra(setup, arrays, duration)
    return metrics


def common_metrics(setup: ScenarioSetup, arrays: dict[str, np.ndarray], result: RunResult) -> Metrics:
    """``survived``, ``fall_time``, ``min_pelvis_height``, ``max_final_error_m``,
    ``max_final_error_rad`` and ``final_error/<task>`` of a run (see the module's docstring)."""
    built = setup.built
    instance = built.info.model_instance
    floating = built.plant.num_positions(instance) == built.plant.num_velocities(instance) + 1
    last = {
        name.removeprefix("error/"): values[-1]
        for name, values in arrays.items()
        if name.startswith("error/") and len(values) and np.isfinite(values[-1]).all()
    }
    by_unit: dict[str, list[float]] = {"m": [], "rad": []}
    for task_name, error in last.items():
        task = built.tasks.get(task_name)
        units = np.array(task.units if isinstance(task, Task | InequalityTask) else ("",) * len(error))
        for unit, norms in by_unit.items():
            if (units == unit).any():
                norms.append(float(np.linalg.norm(error[units == unit])))
    return {
        "survived": result.fell is None,
        "fall_time": math.nan if result.fell is None else result.fell.time,
        "min_pelvis_height": float(arrays["q"][:, 6].min()) if floating else math.nan,  # qw qx qy qz x y z
        "max_final_error_m": max(by_unit["m"], default=math.nan),
        "max_final_error_rad": max(by_unit["rad"], default=math.nan),
        **{f"final_error/{task}": float(np.linalg.norm(error)) for task, error in last.items()},
    }
