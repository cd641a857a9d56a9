"""The ``telecooperation`` scenario standing at 140 ms one way, in physics (Evrard et al. 2009): the
A-weighted admittance against the plain one under a force step on the hand, and the replay's
ghosts of the operator's hands and of the co-operator. Each run is simulated once per module."""

import numpy as np
import pytest
from pydrake.multibody.tree import JacobianWrtVariable
from telecoop_runs import check_standing, hand_error, run_standing

from drake_sot.diagrams import telecooperation as tc
from drake_sot.diagrams.pushes import ExternalPush

pytestmark = pytest.mark.slow


#: A force step on the robot's right hand, standing, before the lift: 10 N forward and 10 N to
#: the left for 50 ms (the hand yields about 5 mm).
STEP_PUSH = ExternalPush(0.6, "right_hand", (10.0, 10.0, 0.0), 0.05)


@pytest.fixture(scope="module", params=tc.ADMITTANCES)
def weighting(request, tmp_path_factory):
    """Standing at 140 ms with each admittance (plain, weighted) and the step push."""
    return run_standing(
        tmp_path_factory, "operator", 0.14, 8.0, admittance=request.param, pushes=(STEP_PUSH,)
    )


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """2.5 s standing at 140 ms, the replay recorded: the operator starts the lift at 1 s."""
    return run_standing(tmp_path_factory, "operator", 0.14, 2.5, record=True)


# --- the A-weighted admittance (III-B, eq. 5-7) against the plain one -----------------------------
def _hand_apparent_inertia(run, k: int) -> np.ndarray:
    """Λ = (J_v A⁻¹ J_vᵀ)⁻¹ (3, 3) [kg] of the right hand's point, from the simulated plant at the
    logged configuration of sample k (Drake's mass matrix and Jacobian, a plain inverse)."""
    plant, instance = run.setup.built.plant, run.setup.built.info.model_instance
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, instance, run.arrays["q"][k])
    hand = plant.GetFrameByName(run.setup.built.info.frames["right_hand"], instance)
    J = plant.CalcJacobianTranslationalVelocity(
        context, JacobianWrtVariable.kV, hand, np.zeros(3), plant.world_frame(), plant.world_frame()
    )
    return np.linalg.inv(J @ np.linalg.solve(plant.CalcMassMatrix(context), J.T))


def _step_response(M: np.ndarray, damping: float, df: np.ndarray, dt: float) -> np.ndarray:
    """The velocity [m/s] after dt of ``M r̈ + b ṙ = Δf`` from rest (the spring's share in a 5 ms
    step is under 1 %), summed over the eigenvectors of M."""
    lam, U = np.linalg.eigh(M)
    return U @ (U.T @ df / damping * (1.0 - np.exp(-damping * dt / lam)))


def _right_hand_force(run) -> np.ndarray:
    """(T, 3) [N] the force driving the right hand's admittance: the wrist sensor's external force
    plus the master's, as received."""
    a = run.arrays
    return a["wrench/e_fr"][:, 3:] + a["received_by_slave/right_hand_force"]


def test_weighted_admittance_the_hand_reference_answers_a_force_step_with_the_hands_apparent_inertia(
    weighting,
):
    """III-B: weighted, the virtual mass is the hand's apparent inertia Λ (computed here from the
    simulated robot), so a force step Δf changes the reference's velocity by what a body of
    inertia Λ would do, not along Δf; plain, by what 4 kg would do. At the push's two edges
    (the measured force jumps by ~10 N) the velocity's jump (second difference of the logged
    reference velocity) is compared with both models."""
    a = weighting.arrays
    weighted = weighting.setup.extras.admittance == "weighted"
    t, v, f = a["time"], a["reference_velocity/e_fr"][:, :3], _right_hand_force(weighting)
    dt = float(np.median(np.diff(t)))
    b = tc.DEFAULT_CONFIG.hand_damping[0]
    plain_mass = tc.DEFAULT_CONFIG.hand_mass[0] * np.eye(3)
    edges = np.flatnonzero(np.linalg.norm(np.diff(f, axis=0), axis=1) > 5.0) + 1
    assert len(edges) == 2 and abs(t[edges[0]] - STEP_PUSH.time) < 0.02
    for k in edges:
        Lam = _hand_apparent_inertia(weighting, k)
        assert np.linalg.cond(Lam) > 2.0  # anisotropic: the two models differ
        jump = (v[k] - v[k - 1]) - (v[k - 1] - v[k - 2])
        df = f[k] - f[k - 1]
        own, other = (Lam, plain_mass) if weighted else (plain_mass, Lam)
        expected = _step_response(own, b, df, dt)
        print(
            f"{weighting.setup.extras.admittance}: t = {t[k]:.3f} s, Δf = {np.round(df, 2)} N, "
            f"Δv = {np.round(jump * 1000, 2)} mm/s, {np.round(expected * 1000, 2)} with its own mass, "
            f"{np.round(_step_response(other, b, df, dt) * 1000, 2)} with the other's"
        )
        assert np.linalg.norm(jump - expected) < 0.08 * np.linalg.norm(expected)
        assert np.linalg.norm(jump - _step_response(other, b, df, dt)) > 0.2 * np.linalg.norm(expected)
    if weighted:  # and the controller's Λ (its model, at its reference q) is the robot's, all along
        for k in range(0, len(t), 100):
            logged = a["virtual_mass/e_fr"][k].reshape(3, 3)
            Lam = _hand_apparent_inertia(weighting, k)
            assert np.linalg.norm(logged - Lam) < 0.05 * np.linalg.norm(Lam)


def test_weighted_admittance_standing_meets_the_same_bounds_as_the_plain_one(weighting):
    """Either admittance, with the step push, standing at 140 ms: upright, the board held, the
    hands within 2 cm of the operator's once settled; prints the comparison (benchmarks/README)."""
    check_standing(weighting)
    a = weighting.arrays
    t = a["time"]
    after = t > 1.0
    f_op, f_robot = a["operator_forces"][after, :3], -a["wrench/e_fr"][after, 3:]
    force_rms = np.sqrt(np.mean(np.sum((f_op - f_robot) ** 2, axis=1)))
    speeds = tc.arm_speeds(weighting.setup, a["v"][after])
    print(
        f"{weighting.setup.extras.admittance}: hand error max "
        f"{100 * hand_error(weighting)[after].max():.2f} cm, force RMS {force_rms:.2f} N, "
        f"shoulder/elbow speed RMS {np.sqrt(np.mean(speeds**2)):.4f} rad/s"
    )


# --- the operator's hands as ghosts in the replay ---------------------------------------------------
def _drawn_sphere(messages: list[dict], path: str) -> tuple[dict, dict, np.ndarray, np.ndarray, float]:
    """The recorded sphere at ``path``: its material, its geometry, and its animation track as
    times [s] (k,) and positions (k, 3) [m], with the recording's frames per second."""
    (drawn,) = [m for m in messages if m.get("type") == "set_object" and m["path"] == path]
    (material,) = drawn["object"]["materials"]
    (geometry,) = drawn["object"]["geometries"]
    (animation,) = [m for m in messages if m.get("type") == "set_animation"]
    (clip,) = [track["clip"] for track in animation["animations"] if track["path"] == path]
    (position,) = [track for track in clip["tracks"] if track["name"] == ".position"]
    times = np.array([key["time"] for key in position["keys"]]) / clip["fps"]
    return material, geometry, times, np.array([key["value"] for key in position["keys"]]), clip["fps"]


def test_the_replay_draws_the_operators_hands_as_translucent_ghosts_that_move_as_logged(recorded):
    """The recorded page holds a translucent sphere per operator hand
    (``tc.DEFAULT_CONFIG.ghost_paths``) and an animation track for each whose keyframes are the
    logged ``operator_hands`` (the handles), the lift included."""
    from replay_html import replay_messages

    messages = replay_messages(recorded.files["html"])
    a = recorded.arrays
    for k, path in enumerate(tc.DEFAULT_CONFIG.ghost_paths):
        material, geometry, times, drawn_at, _ = _drawn_sphere(messages, path)
        assert material["transparent"] and 0.0 < material["opacity"] < 1.0
        assert geometry["type"] == "SphereGeometry" and geometry["radius"] == tc.DEFAULT_CONFIG.ghost_radius
        assert times[-1] > 2.0  # the whole run
        logged = np.column_stack(
            [np.interp(times, a["time"], a["operator_hands"][:, 3 * k + j]) for j in range(3)]
        )
        np.testing.assert_allclose(drawn_at, logged, atol=1e-3)  # [m]
        assert np.ptp(drawn_at[:, 2]) > 0.01  # it moves: the operator lifts


def test_the_replay_draws_the_cooperator_where_they_pull_the_boards_far_end(recorded):
    """The co-operator's translucent sphere (``tc.DEFAULT_CONFIG.cooperator_ghost_path``) moves as
    the logged target of their impedance, the point their spring pulls the board's far end to."""
    from pydrake.common.eigen_geometry import Quaternion
    from pydrake.math import RigidTransform, RotationMatrix
    from replay_html import replay_messages

    a = recorded.arrays
    material, _, times, drawn_at, fps = _drawn_sphere(
        replay_messages(recorded.files["html"]), tc.DEFAULT_CONFIG.cooperator_ghost_path
    )
    assert material["transparent"] and 0.0 < material["opacity"] < 1.0
    logged = np.column_stack([np.interp(times, a["time"], a["cooperator_target"][:, j]) for j in range(3)])
    # Meshcat's recording files a publish under a frame of 1/fps s (seen: the value of 2.065 s at
    # the frame of 2.033 s), so the drawn point may be the logged one up to a frame later: the
    # tolerance is the target's fastest motion over one frame.
    speed = np.max(np.abs(np.diff(a["cooperator_target"], axis=0)) / np.diff(a["time"])[:, None])
    np.testing.assert_allclose(drawn_at, logged, atol=speed / fps + 1e-4)  # [m]
    assert np.ptp(drawn_at[:, 2]) > 0.01  # it moves: the co-operator follows the lift
    # The target is where the co-operator's impedance pulls the far end to: their logged force is
    # k (target - far end) + b (target's rate - far end's velocity), the far end's pose and velocity
    # computed in the test from the board's logged state ([q; ω; v], world frame).
    stiffness, damping = tc.DEFAULT_CONFIG.follower_impedance  # the operator leads this run
    far_end = np.array([0.5 * tc.DEFAULT_CONFIG.board_length, 0.0, 0.0])
    rate = np.gradient(a["cooperator_target"], a["time"], axis=0)
    worst = 0.0
    for k in range(len(a["time"]) // 5, len(a["time"]), 10):
        q, w, v = a["board_state"][k, :7], a["board_state"][k, 7:10], a["board_state"][k, 10:13]
        X = RigidTransform(RotationMatrix(Quaternion(q[:4] / np.linalg.norm(q[:4]))), q[4:7])
        r = X.rotation() @ far_end
        law = stiffness * (a["cooperator_target"][k] - X @ far_end) + damping * (rate[k] - v - np.cross(w, r))
        worst = max(worst, float(np.linalg.norm(a["cooperator_force"][k] - law)))
    print(f"co-operator force against k (target - far end) + b (rate - velocity): worst {worst:.3f} N")
    assert worst < 0.5  # [N] of ~10


def test_the_replay_draws_the_cooperators_pull_as_an_arrow_with_its_legend(recorded):
    """The co-operator's force on the board's far end is an arrow of the replay (a shaft and a
    head, shown at some frames), named in the page's legend."""
    import html

    from replay_html import replay_messages

    messages = replay_messages(recorded.files["html"])
    drawn = {m["path"] for m in messages if m.get("type") == "set_object"}
    assert {"/forces/cooperator/0/shaft/cylinder", "/forces/cooperator/0/head/cone"} <= drawn
    (animation,) = [m for m in messages if m.get("type") == "set_animation"]
    tracks = [a for a in animation["animations"] if a["path"].startswith("/forces/cooperator/0")]
    assert tracks, "the arrow is never moved in the recording"
    assert "co-operator's pull on the board" in html.unescape(recorded.files["html"].read_text())
