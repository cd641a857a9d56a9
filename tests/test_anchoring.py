"""Planar transforms and the re-anchoring of a walking plan (drake_sot.anchoring), checked
against 3×3 homogeneous matrices, and the drift argument of its docstring on a kinematic
model of a walk written here with those matrices."""

import math

import numpy as np
import pytest

from drake_sot.anchoring import PlanarTransform, blend, drift


def _matrix(t: PlanarTransform) -> np.ndarray:
    c, s = math.cos(t.yaw), math.sin(t.yaw)
    return np.array([[c, -s, t.x], [s, c, t.y], [0.0, 0.0, 1.0]])


def _from_matrix(m: np.ndarray) -> PlanarTransform:
    return PlanarTransform(m[0, 2], m[1, 2], math.atan2(m[1, 0], m[0, 0]))


def _random(rng: np.random.Generator, scale: float = 1.0) -> PlanarTransform:
    return PlanarTransform(*(scale * rng.uniform(-1, 1, 2)), rng.uniform(-math.pi, math.pi))


@pytest.mark.parametrize("seed", range(5))
def test_compose_inverse_and_apply_agree_with_homogeneous_matrices(seed):
    rng = np.random.default_rng(seed)
    a, b = _random(rng), _random(rng)
    np.testing.assert_allclose(_matrix(a.compose(b)), _matrix(a) @ _matrix(b), atol=1e-12)
    np.testing.assert_allclose(_matrix(a.inverse()), np.linalg.inv(_matrix(a)), atol=1e-12)
    p = rng.uniform(-1, 1, 2)
    np.testing.assert_allclose(a.apply_point(p), (_matrix(a) @ [*p, 1.0])[:2], atol=1e-12)
    np.testing.assert_allclose(a.rotate(p), (_matrix(a) @ [*p, 0.0])[:2], atol=1e-12)


@pytest.mark.parametrize("seed", range(5))
def test_drift_maps_the_measured_pose_onto_the_reference(seed):
    rng = np.random.default_rng(seed)
    reference, measured = _random(rng), _random(rng)
    d = drift(reference, measured)
    np.testing.assert_allclose(_matrix(d) @ _matrix(measured), _matrix(reference), atol=1e-12)


def test_blend_ends_and_turns_the_short_way():
    a, b = PlanarTransform(0.0, 0.0, 3.0), PlanarTransform(1.0, -2.0, -3.0)
    assert blend(a, b, 0.0) == a
    end = blend(a, b, 1.0)
    assert (end.x, end.y) == (1.0, -2.0)
    assert math.remainder(end.yaw - b.yaw, 2 * math.pi) == pytest.approx(0.0, abs=1e-12)
    # 3 rad to -3 rad is 0.28 rad through π, not 6 rad through 0
    assert abs(blend(a, b, 0.5).yaw - (3.0 + 0.5 * (2 * math.pi - 6.0))) < 1e-12
    for bad in (-0.1, 1.1, float("nan")):
        with pytest.raises(ValueError, match="s"):
            blend(a, b, bad)


def test_planar_transform_refuses_nan():
    with pytest.raises(ValueError, match="PlanarTransform.yaw"):
        PlanarTransform(0.0, 0.0, float("nan"))


def _walk(anchored: bool, n: int = 30, seed: int = 0) -> np.ndarray:
    """Landing errors [m] of a kinematic walk in homogeneous matrices: footprints ``F``, the
    reference's soles put exactly on their targets, the robot's swing sole landing where its
    legs put it relative to its stance sole, with a relative error ``E`` per step (2.5 mm
    short, ±1 mm and ±0.2° of noise)."""
    rng = np.random.default_rng(seed)
    H = _matrix
    F = [H(PlanarTransform(0.0, 0.1, 0.0)), H(PlanarTransform(0.0, -0.1, 0.0))]
    for k in range(n):
        turn = 0.2 if 8 <= k < 14 else 0.0
        F.append(F[-1] @ H(PlanarTransform(0.2, 0.2 if k % 2 else -0.2, turn)))
    ref = list(F[:2])  # the reference's soles
    meas = list(F[:2])  # the robot's soles
    errors = []
    for k in range(2, n + 2):
        stance_r, stance_m = ref[k - 1], meas[k - 1]
        d = drift(_from_matrix(stance_r), _from_matrix(stance_m)) if anchored else PlanarTransform()
        target = H(d) @ F[k]
        E = H(PlanarTransform(-0.0025 + rng.normal(0, 1e-3), rng.normal(0, 1e-3), rng.normal(0, 0.0035)))
        ref.append(target)
        meas.append(stance_m @ np.linalg.inv(stance_r) @ target @ E)
        errors.append(np.linalg.norm(meas[-1][:2, 2] - F[k][:2, 2]))
    return np.array(errors)


def test_open_loop_errors_add_up_and_anchored_ones_do_not():
    open_loop, anchored = _walk(False), _walk(True)
    assert open_loop[-1] > 0.03  # the running sum: about 2.5 mm a step
    assert anchored.max() < 0.006  # one step's error (2.5 mm + 2.5 σ of noise)
    assert anchored[-10:].mean() <= anchored[:10].mean() + 1e-3
