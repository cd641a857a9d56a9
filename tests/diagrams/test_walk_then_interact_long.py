"""The case study run for 25 s: its walk ends near 5 s and the pattern generator stands on past the
20 s of executed samples it keeps (the run failed at 20.005 s when it kept none past its plan)."""

import numpy as np
import pytest

from drake_sot.diagrams import walk_then_interact as wti
from drake_sot.diagrams.scenario import run_scenario

pytestmark = pytest.mark.slow

DURATION = 25.0  # [s]


@pytest.fixture(scope="module")
def long_run(tmp_path_factory):
    return run_scenario(wti.SCENARIO, tmp_path_factory.mktemp("wti_long"), duration=DURATION, record=False)


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


def test_the_case_study_run_for_25_s_completes_upright(long_run):
    result = long_run.result
    assert result.completed and result.fell is None, result.failure
    assert long_run.arrays["time"][-1] == pytest.approx(DURATION, abs=0.006)
    assert long_run.arrays["q"][:, 6].min() > 0.55  # pelvis height [m]: it stands at 0.61


def test_after_the_walk_the_feet_stay_on_the_last_footprints(long_run):
    last = {step.side: step for step in long_run.setup.extras.steps}
    t, soles = _soles(long_run)
    standing = t > wti.GRIP_AT  # the walk ended near 5 s
    for side, step in last.items():
        assert np.abs(soles[side][standing] - step.xy).max() < 0.02, side


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
