"""The case study end to end in physics: walk, the decision rule switches tasks, the hands comply;
run for 25 s, its walk ends near 5 s and the pattern generator stands on past the 20 s of executed
samples it keeps (the run failed at 20.005 s when it kept none past its plan); and the decision
layer as the paper ran it, a separate client process, switches the stack as the sequencer does.

The tests share one run, the sequencer's. The case study's own tests (``compat``: every Python the
package claims runs them) hold on any run that contains its 15 s; the long ones (``slow``: the main
Python only) need 25 s. So the run lasts 25 s when a ``slow`` test is selected (the whole suite),
the case study's own 15 s when none is (``make test``'s runs on the other Pythons): one simulation
in the diagram either way, where there were three on the main Python (the 15 s run, the 25 s one,
and the sequencer's beside the remote decision layer's)."""

import subprocess

import numpy as np
import pytest
from joint_limits import limit_excess
from served import DRAKE_SOT, REPO

from drake_sot.diagrams import walk_then_interact as wti
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.diagrams.tasks import SELF_COLLISION_TASK

#: [s] the long run, past the 20 s of executed samples the pattern generator keeps.
LONG = 25.0


@pytest.fixture(scope="module")
def case_study(request, tmp_path_factory):
    """The case study's run and its output directory: ``LONG`` when a ``slow`` test of this module
    is selected, else the scenario's own duration (15 s)."""
    long = any(
        item.module is request.module and item.get_closest_marker("slow") for item in request.session.items
    )
    out_dir = tmp_path_factory.mktemp("wti")
    output = run_scenario(wti.SCENARIO, out_dir, duration=LONG if long else None, record=False)
    assert output.result.completed, output.result.failure
    return output, out_dir


@pytest.fixture
def long_run(case_study):
    """The run of ``LONG`` seconds: ``case_study``'s, a ``slow`` test being selected."""
    return case_study[0]


def _stacks(arrays):
    return [(t, s.split(" > ")) for t, s in zip(arrays["stack_time"], arrays["stack"], strict=True)]


@pytest.mark.compat
def test_walking_tasks_removed_and_force_tasks_pushed_after_the_walk(case_study):
    output, _ = case_study
    arrays = output.arrays
    stacks = _stacks(arrays)
    assert stacks[0][1] == [
        wti.STACK[0],
        SELF_COLLISION_TASK,
        *wti.STACK[1:],
    ]  # walking, the task on by default
    t_switch, after = stacks[-1]
    for task in wti.WALKING_TASKS:
        assert task not in after
    for task in wti.FORCE_TASKS:
        assert after.index(task) < after.index("taskPosture")  # pushed, then raised above the posture
    # The switch came after the walk ended, at the decision rule's next 1 s check.
    t = arrays["time"]
    walk_end = t[np.flatnonzero(arrays["in_process"][:, 0] > 0.5)[-1]]
    # Recorded at the first tick after a check instant (every 1 s), at most one check after the walk.
    check = np.floor(t_switch)
    assert t_switch - check <= 0.005 + 1e-9
    assert walk_end < check <= walk_end + 1.0 + 1e-9
    assert arrays["transitions"][-1, 0] == 2  # standing -> walking -> interacting
    assert np.all(np.isnan(arrays["error/taskForce"][t < t_switch - 0.01]))
    assert np.all(np.isfinite(arrays["error/taskForce"][t > t_switch + 0.01]))


@pytest.mark.compat
def test_hands_comply_with_the_partner_and_the_robot_stays_up(case_study):
    output, _ = case_study
    arrays = output.arrays
    t = arrays["time"]
    hands = wti.hand_positions(output.setup, arrays)
    grip = np.searchsorted(t, wti.GRIP_AT)
    pulled = np.searchsorted(t, wti.GRIP_AT + 2.0)  # the partner's grip is 8 cm forward then
    for side in ("right", "left"):
        moved = hands[side][pulled] - hands[side][grip]
        assert moved[0] > 0.04, f"{side} hand did not follow the pull ({moved[0]:.3f} m)"
    assert arrays["q"][:, 6].min() > 0.6
    assert np.all(arrays["fault/taskForce"] == 0) and np.all(arrays["fault/taskForceLH"] == 0)


@pytest.mark.compat
def test_artefacts(case_study):
    _, out_dir = case_study
    for name in (
        "walk_then_interact.svg",
        "walk_then_interact.png",
        "walk_then_interact.npz",
        "walk_then_interact_hands.png",
    ):
        assert (out_dir / name).stat().st_size > 1000, name


@pytest.mark.compat
def test_no_joint_passes_its_position_or_velocity_limit(case_study):
    """Joint position and velocity limits on top of the stack (solver "hqp") through the walk, the
    switch of tasks and the partner's pulls, measured on the plant."""
    output, _ = case_study
    excess = limit_excess(output.setup.built, output.arrays)
    assert excess.position < 1e-3, f"{excess.position_joint} {excess.position:.4f} rad past its limit"
    assert excess.velocity < 1e-3, f"{excess.velocity_joint} {excess.velocity:.4f} rad/s past its limit"
    # The reference stays the margin (0.02 rad) inside: the plant alone would not tell (Drake's
    # discrete plant holds a joint at its limit; without the limit tasks reach's reference went
    # 0.079 rad past chest_pitch's while the plant stayed within 3e-8 rad of it).
    assert excess.reference <= -0.02 + 1e-9, f"reference {excess.reference_joint} {excess.reference:.4f}"


# --- the case study run for 25 s ---------------------------------------------------------------------
def _soles(run, every: int = 20) -> tuple[np.ndarray, dict[str, np.ndarray]]:
    """The times [s] (K,) of every ``every``-th sample and, per side, the sole's (K, 2) x, y [m]
    in the simulated plant at the logged configuration."""
    plant, info = run.setup.built.plant, run.setup.built.info
    context = plant.CreateDefaultContext()
    frames = {
        side: plant.GetFrameByName(info.frames[f"{side}_foot"], info.model_instance)
        for side in ("left", "right")
    }
    samples = range(0, len(run.arrays["time"]), every)
    soles = {side: np.zeros((len(samples), 2)) for side in frames}
    for i, k in enumerate(samples):
        plant.SetPositions(context, info.model_instance, run.arrays["q"][k])
        for side, frame in frames.items():
            soles[side][i] = frame.CalcPoseInWorld(context).translation()[:2]
    return run.arrays["time"][::every], soles


@pytest.mark.slow
def test_the_case_study_run_for_25_s_completes_upright(long_run):
    result = long_run.result
    assert result.completed and result.fell is None, result.failure
    assert long_run.arrays["time"][-1] == pytest.approx(LONG, abs=0.006)
    assert long_run.arrays["q"][:, 6].min() > 0.55  # pelvis height [m]: it stands at 0.61


@pytest.mark.slow
def test_after_the_walk_the_feet_stay_on_the_last_footprints(long_run):
    last = {step.side: step for step in long_run.setup.extras.steps}
    t, soles = _soles(long_run)
    standing = t > wti.GRIP_AT  # the walk ended near 5 s
    for side, step in last.items():
        assert np.abs(soles[side][standing] - step.xy).max() < 0.02, side


@pytest.mark.slow
def test_the_feet_com_and_force_tasks_stay_converged_past_the_samples_the_generator_keeps(long_run):
    """From 20 s on (the partner let go at 14 s): the feet, the CoM on the generator's standing
    reference, the hands' force tasks, each error under 1e-4 (m, rad or N); the stack is still the
    one the decision rule switched to."""
    a = long_run.arrays
    late = a["time"] > 20.0
    for task in ("taskLF", "taskRF", "taskCom", *wti.FORCE_TASKS):
        assert np.linalg.norm(a[f"error/{task}"][late], axis=1).max() < 1e-4, task
    assert a["stack"][-1].split(" > ")[-3:-1] == list(wti.FORCE_TASKS)
    assert a["stack_time"][-1] < 10.0  # the switch after the walk, the last change


# --- the case study as the paper ran it: the decision layer as a separate client process ----------
@pytest.mark.slow
def test_a_remote_decision_layer_switches_the_stack_as_the_sequencer_does(case_study, tmp_path):
    """``drake-sot run walk_then_interact --decision remote`` (the decision layer a client process
    sending script lines) switches the stack as the sequencer in the diagram does (this module's
    run, ``--decision sequencer`` being the default): the same stacks, the switch within one poll
    period (1 s) of the sequencer's."""
    proc = subprocess.run(
        [
            *DRAKE_SOT,
            "run",
            "walk_then_interact",
            "--decision",
            "remote",
            "--out",
            str(tmp_path),
            "--no-record",
        ],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    with np.load(tmp_path / "walk_then_interact.npz") as npz:
        t_remote, stacks_remote = list(npz["stack_time"]), list(npz["stack"])
    sequencer = case_study[0].arrays
    t_seq, stacks_seq = list(sequencer["stack_time"]), list(sequencer["stack"])
    assert stacks_remote == stacks_seq and len(stacks_seq) == 2  # walking, then the force tasks at one tick
    assert "taskForce" in stacks_seq[1] and "taskRHwaist" not in stacks_seq[1]
    assert abs(t_remote[1] - t_seq[1]) <= 1.0  # within one poll period (1 s)
