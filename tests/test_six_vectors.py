"""The README's 6-vector conventions, checked against the code by finite differences on a small
plant: Drake's frame Jacobian has rows ``[ω; v]``, a 6D feature's error and Jacobian are
``[translation; rotation]``, and its ``velocity_des`` is ``[v*; ω*]``."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from pydrake.math import RigidTransform, RollPitchYaw
from pydrake.multibody.plant import MultibodyPlant
from pydrake.multibody.tree import (
    FixedOffsetFrame,
    JacobianWrtVariable,
    PrismaticJoint,
    RevoluteJoint,
    SpatialInertia,
)

from drake_sot import features, so3

H = 1e-6  # [s] finite-difference step


def _arm() -> tuple[MultibodyPlant, FixedOffsetFrame]:
    """A fixed-base arm: a prismatic joint along x, revolute joints about z and y, and a tool frame
    offset and turned from the last body, so that every row of its Jacobian is non-zero somewhere."""
    plant = MultibodyPlant(0.0)
    inertia = SpatialInertia.SolidBoxWithMass(1.0, 0.1, 0.1, 0.1)
    parent = plant.world_frame()
    joints = (
        (PrismaticJoint, [1.0, 0.0, 0.0]),
        (RevoluteJoint, [0.0, 0.0, 1.0]),
        (RevoluteJoint, [0.0, 1.0, 0.0]),
    )
    for k, (joint, axis) in enumerate(joints):
        body = plant.AddRigidBody(f"link{k}", inertia)
        plant.AddJoint(joint(f"joint{k}", parent, body.body_frame(), axis))
        parent = body.body_frame()
    X_tool = RigidTransform(RollPitchYaw(0.3, -0.2, 0.5), [0.2, 0.1, 0.4])
    tool = plant.AddFrame(FixedOffsetFrame("tool", parent, X_tool))
    plant.Finalize()
    return plant, tool


def test_the_frame_jacobian_is_omega_then_v_and_the_feature_is_translation_then_rotation():
    plant, tool = _arm()
    context = plant.CreateDefaultContext()
    q0 = np.array([0.1, 0.4, -0.3])
    v = np.array([0.7, -1.1, 0.9])  # fixed base, scalar joints: q̇ = v

    def pose(q):
        plant.SetPositions(context, q)
        X = tool.CalcPoseInWorld(context)
        return X.rotation().matrix(), X.translation()

    R0, p0 = pose(q0)
    R1, p1 = pose(q0 + H * v)
    omega = so3.log(R1 @ R0.T) / H  # world-frame angular velocity
    plant.SetPositions(context, q0)
    J = plant.CalcJacobianSpatialVelocity(
        context, JacobianWrtVariable.kV, tool, np.zeros(3), plant.world_frame(), plant.world_frame()
    )
    np.testing.assert_allclose(J[:3] @ v, omega, atol=1e-5)  # rows [ω; v]
    np.testing.assert_allclose(J[3:] @ v, (p1 - p0) / H, atol=1e-5)

    # The 6D feature: error [p - p*; rotation], its Jacobian in the same order.
    R_des, p_des = RollPitchYaw(0.1, 0.2, -0.3).ToRotationMatrix().matrix(), np.array([0.5, -0.2, 0.6])
    e0, J_e, _ = features.point6d(R0, p0, J, R_des, p_des)
    e1, _, _ = features.point6d(R1, p1, J, R_des, p_des)
    np.testing.assert_allclose(e0[:3], p0 - p_des, atol=1e-12)  # translation first
    np.testing.assert_allclose(J_e @ v, (e1 - e0) / H, atol=1e-5)

    # velocity_des = [v*; ω*]: the reference moving at v* and ω* changes the error by -feedforward.
    v_des, w_des = np.array([0.2, -0.1, 0.3]), np.array([-0.4, 0.5, 0.2])
    _, _, feedforward = features.point6d(R0, p0, J, R_des, p_des, np.concatenate((v_des, w_des)))
    moved, _, _ = features.point6d(R0, p0, J, so3.exp(H * w_des) @ R_des, p_des + H * v_des)
    np.testing.assert_allclose(feedforward, -(moved - e0) / H, atol=1e-5)


def test_the_readme_states_every_six_vector_convention():
    readme = (Path(__file__).resolve().parent.parent / "README.md").read_text(encoding="utf-8")
    section = readme.split("### Six-vectors", 1)
    assert len(section) == 2, "README.md has no '### Six-vectors' section"
    body = section[1].split("\n## ", 1)[0]
    for convention in (
        "`[ω; v]`",
        "`[p − p*; log(R R*ᵀ)]`",
        "`[x, y, z, rx, ry, rz]`",
        "`[v*; ω*]`",
        "`[τ; f]`",
    ):
        assert convention in body, convention
