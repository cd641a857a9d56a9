"""The ``telecooperation`` scenario's whole walk in physics (Evrard et al. 2009), at 140 ms one
way with each leader: the operator here, the co-operator in
``test_telecooperation_walking_cooperator.py`` (the same tests). Each run is simulated once per
class."""

import numpy as np
import pytest
from collision_queries import Query
from telecoop_runs import grip_stretch, hand_error

from drake_sot.diagrams import SCENARIOS
from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.scenario import run_scenario
from drake_sot.robots import EMBEDDED
from drake_sot.support import sole_corners, support_polygon

pytestmark = pytest.mark.slow

D_S = (
    0.01  # [m] the self-collision task's margin (add_self_collision_task's default, which the scenario keeps)
)


def _end(run) -> float:
    return run.result.end_time if run.result.fell is None else run.result.fell.time


def _ripple_rms(time: np.ndarray, force: np.ndarray) -> np.ndarray:
    """(W,) [N] the RMS over each whole second of the run of the force's ripple: ``force`` (T, 3)
    [N] less its 0.05 s moving mean (what varies faster than about 20 Hz). The force itself is
    the board's weight and the pull (7 N, the median over 1 s windows), which a ±15 N burst of
    0.3 s raises by only half; its ripple is the landings' impacts (0.24 N) and the bursts."""
    n = int(round(0.05 / (time[1] - time[0])))
    kernel = np.ones(n) / n
    ripple = force - np.column_stack([np.convolve(force[:, i], kernel, mode="same") for i in range(3)])
    return np.array(
        [
            np.sqrt(np.mean(np.sum(ripple[(time >= s) & (time < s + 1.0)] ** 2, axis=1)))
            for s in np.arange(np.floor(time[-1]))
        ]
    )


def least_distance(run, every: int = 4) -> tuple[float, float, str]:
    """The least signed distance [m] between two of the simulated robot's collision shapes that may
    collide (the legs' pairs included) over the run until its end or fall, every ``every``-th
    sample, on a collision model of the test's own; its time [s] and its pair of bodies (inf, NaN
    and "" when no pair comes within ``2 D_S``)."""
    query = Query(EMBEDDED)
    a = run.arrays
    least = (np.inf, np.nan, "")
    for k in np.flatnonzero(a["time"] < _end(run))[::every]:
        for distance, points in query.near(a["q"][k], 2 * D_S).values():
            if distance < least[0]:
                least = (distance, float(a["time"][k]), "-".join(sorted(body for body, _ in points.values())))
    return least


def _zmp_inside(run) -> np.ndarray:
    """(T,) the measured ZMP inside the support polygon: the soles of the simulated robot whose
    ankle sensor reads more than 10 N, at their measured poses; NaN where the ZMP is undefined."""
    a = run.arrays
    plant, info = run.setup.built.plant, run.setup.built.info
    context = plant.CreateDefaultContext()
    soles = [
        plant.GetFrameByName(info.frames[f"{side}_foot"], info.model_instance) for side in ("left", "right")
    ]
    inside = np.full(len(a["time"]), np.nan)
    for k, (q, zmp, forces) in enumerate(zip(a["q"], a["zmp"], a["foot_forces"], strict=True)):
        if not np.all(np.isfinite(zmp)):
            continue
        plant.SetPositions(context, info.model_instance, q)
        corners = []
        for frame, force in zip(soles, forces, strict=True):
            if force > 10.0:
                X = frame.CalcPoseInWorld(context)
                yaw = np.arctan2(X.rotation().matrix()[1, 0], X.rotation().matrix()[0, 0])
                corners.append(sole_corners(*X.translation()[:2], yaw, info.sole_size))
        polygon = support_polygon(corners)
        edge = np.roll(polygon, -1, axis=0) - polygon
        cross = edge[:, 0] * (zmp[1] - polygon[:, 1]) - edge[:, 1] * (zmp[0] - polygon[:, 0])
        inside[k] = float(np.all(cross >= 0.0))
    return inside


class WalkingChecks:
    """The tests of the whole walk at 140 ms one way, with the leader a subclass names (``LEADER``):
    one subclass per leader, each in its own file (this one and
    ``test_telecooperation_walking_cooperator.py``), so that ``--dist loadfile`` can give the two
    runs, the longest of the suite, to the two workers."""

    LEADER: str

    @pytest.fixture(scope="class")
    @classmethod
    def walking(cls, tmp_path_factory):
        """The whole scenario at 140 ms one way, ``LEADER`` leading."""
        return run_scenario(
            SCENARIOS["telecooperation"],
            tmp_path_factory.mktemp(f"walking_{cls.LEADER}"),
            record=False,
            parameters={"leader": cls.LEADER, "delay": 0.14},
        )

    def test_walking_steps_are_decided_above_the_threshold_and_each_reduces_the_error(self, walking):
        a = walking.arrays
        stance, error = a["planned_stance"], np.linalg.norm(a["step_error"], axis=1)
        changed = np.flatnonzero(np.any(np.abs(np.diff(stance, axis=0)) > 1e-9, axis=1))
        assert len(changed) >= 4, "the walk needs steps"
        assert np.all(error[changed] >= tc.DEFAULT_CONFIG.step_threshold)  # the sample before the footprint
        assert np.all(error[changed + 1] < error[changed])

    def test_walking_the_altitude_tasks_are_in_the_stack_only_while_walking(self, walking):
        a = walking.arrays
        walking_flag = a["in_process"][:, 0] > 0.5
        edges = np.flatnonzero(np.diff(walking_flag.astype(int)) != 0)
        away = np.ones(len(walking_flag), dtype=bool)
        for e in edges:
            away[max(e - 2, 0) : e + 3] = False  # the switch acts at the tick after the flag
        assert walking_flag.any() and (~walking_flag).any()
        for task in tc.ALTITUDE_TASKS:
            active = np.all(np.isfinite(a[f"error/{task}"]), axis=1)
            np.testing.assert_array_equal(active[away], walking_flag[away])

    def test_walking_the_hands_follow_the_operators_until_the_first_landing(self, walking):
        a = walking.arrays
        t = a["time"]
        phase = a["phase"][:, 0]
        first_landing = t[np.flatnonzero((phase[:-1] != 0) & (phase[1:] == 0))[0] + 1]
        assert first_landing > tc.DEFAULT_CONFIG.walk_at
        assert hand_error(walking)[(t > 1.0) & (t < first_landing)].max() <= 0.02

    def test_walking_the_hands_follow_the_operators_within_5_cm(self, walking):
        t = walking.arrays["time"]
        assert hand_error(walking)[(t > 1.0) & (t < _end(walking))].max() <= 0.05

    def test_walking_the_board_is_never_dropped(self, walking):
        """Until the end of the run, or until the robot falls."""
        a = walking.arrays
        before = a["time"] < _end(walking)
        assert grip_stretch(walking)[before[::20]].max() < 0.03  # the board never leaves the hands
        assert a["board_state"][before, 6].min() > 0.4

    def test_walking_the_robot_stays_upright_to_the_end(self, walking):
        """With either leader. With the co-operator leading the balance is marginal (see the
        scenario's docstring): a fall here says the margin went."""
        assert walking.result.fell is None
        a = walking.arrays
        assert a["q"][:, 6].min() > 0.55  # pelvis height [m]
        # The robot went where the leader took the board: 2 m forward, 0.5 m to the right.
        np.testing.assert_allclose(a["q"][-1, 4:6] - a["q"][0, 4:6], [2.0, -0.5], atol=0.15)

    def test_walking_the_robots_shapes_stay_the_self_collision_margin_apart(self, walking):
        """The self-collision task (on by default, below the joint limits) keeps the simulated
        robot's shapes ``D_S`` apart over the whole walk. Without it the co-operator-led walk
        brought the left forearm to 4.7 mm of the torso at 48.0 s (1.4 cm with it); with the
        operator leading the least is the same forearm's, 1.9 cm, with or without it."""
        distance, time, bodies = least_distance(walking)
        assert distance > D_S, f"{bodies} {distance:.4f} m apart at {time:.2f} s"

    @pytest.mark.xfail(
        strict=True, reason="the CoM's height level, singular with an elbow at its limit, chatters"
    )
    def test_walking_the_wrist_forces_have_no_bursts(self, walking):
        """Over each 1 s window the ripple of the force measured at each wrist stays within 3 times
        the run's median. It does not, with either leader: 33 Hz bursts when an elbow is held at its
        joint limit and the hand's position task chatters against it in the solver (11 to 18 times
        the median at 7, 11, 15, 19 and 23 s with the co-operator leading, 11 times at 6 s with the
        operator), and the feet's landings and lift-offs late in the walk (3 to 9 times); the
        scenario's docstring has the measurements (the chattering level is ``taskComZ``'s, which the
        joint limit leaves singular; damping it removes the bursts at 7-23 s, but not the later ones,
        and costs the co-operator-led balance). An expected failure, strict, so that a fix shows."""
        a = walking.arrays
        for task in tc.HAND_TASKS:
            rms = _ripple_rms(a["time"], a[f"wrench/{task}"][:, 3:])
            median = float(np.median(rms))
            bursts = {
                int(s): round(float(r / median), 1) for s, r in enumerate(rms) if not (r <= 3.0 * median)
            }
            assert not bursts, (
                f"{task}: the ripple over 1 s windows, times its median {median:.2f} N: {bursts}"
            )

    def test_walking_the_stabilizer_with_the_hands_wrenches_keeps_its_offset_off_its_bound(self, walking):
        """With the hands' measured wrenches in the stabilizer's model (the co-operator's pull and the
        board's weight), the walk completes upright, the measured ZMP stays in the support polygon,
        and the CoM offset is far less often at its bound than without them (76 % of the co-operator-led
        walk, measured before the change; 37 % with it, the rest a drift late in the walk)."""
        run = walking
        if run.setup.extras.leader != "cooperator":
            pytest.skip("the hands' wrenches reach the stabilizer only with the co-operator leading")
        assert run.result.fell is None
        a = run.arrays
        assert a["q"][:, 6].min() > 0.55  # pelvis height [m]
        inside = _zmp_inside(run)
        defined = np.isfinite(inside)
        share = float(np.mean(inside[defined]))
        at_bound = np.abs(a["stabilizer_offset"]) >= tc.DEFAULT_CONFIG.stabilizer.max_offset - 1e-9
        bound_share = float(at_bound.any(axis=1).mean())
        print(
            f"{run.setup.extras.leader}: ZMP inside the support polygon in {100 * share:.2f} % of "
            f"{defined.sum()} samples; the offset at its bound {100 * bound_share:.1f} % of the time, "
            f"max |offset| {np.abs(a['stabilizer_offset']).max(axis=0)} m"
        )
        assert defined.mean() > 0.95  # the feet carried the robot throughout
        assert share >= 0.97
        assert bound_share < 0.5


class TestOperatorLeading(WalkingChecks):
    LEADER = "operator"
