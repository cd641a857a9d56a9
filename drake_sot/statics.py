"""Joint torques of a floating-base robot in contact, and the ZMP of ground wrenches. Pure numpy.

Equation of motion: ``M a + C v - τ_g = Sᵀ τ + J_cᵀ f``; call the left side ``τ_id``
(what inverse dynamics returns; ``-τ_g`` at rest), ``S`` the actuated-joint selection
and ``J_c`` the stacked contact Jacobians (k, nv). The base rows (no actuation) fix the
contact wrenches up to the internal ones; the joint rows then give the torques.
"""

from __future__ import annotations

import numpy as np

from drake_sot.linalg import pinv
from drake_sot.validation import matrix, nonnegative, per_axis, positive_int, vector


def contact_torques(
    tau_id: np.ndarray, J_contacts: np.ndarray, n_base: int = 6, weights: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques that produce a motion of a floating-base robot on its contacts.

    The contact wrenches solve the base rows ``τ_id[:n_base] = J_c[:, :n_base]ᵀ f``
    with the least weighted norm ``Σ ‖f_i‖² / w_i`` (no internal squeeze between
    contacts; a contact of weight 0 carries nothing, and the load moves between
    contacts as their weights do). With no loaded contact the base is unsupported and
    the joint rows of ``τ_id`` are returned.

    Args:
        tau_id: ``M a + C v - τ_g`` (nv,), e.g. Drake's ``CalcInverseDynamics`` with
            gravity among the applied forces; ``-τ_g`` for the robot at rest.
        J_contacts: stacked contact Jacobians (k, nv), k = 6 per contact.
        n_base: number of unactuated base velocities (6 for a free flyer, 0 for a fixed base).
        weights: (k / 6,) non-negative share of each contact; None for equal shares.
    Returns:
        ``(τ (nv - n_base,) [N·m], f (k,))``: joint torques and contact wrenches.
    Raises:
        ValueError: sizes that disagree, NaN or Inf, a negative weight (each named).
    """
    n_base = positive_int("n_base", n_base, minimum=0)
    tau_id = vector("tau_id", tau_id)
    J_contacts = matrix("J_contacts", J_contacts, (None, tau_id.size))
    k = J_contacts.shape[0]
    if k % 6 or not n_base <= tau_id.size:
        raise ValueError(
            f"J_contacts has {k} rows (6 per contact) and n_base = {n_base} for {tau_id.size} velocities"
        )
    weights = np.ones(k // 6) if weights is None else per_axis("weights", weights, k // 6, sign="nonnegative")
    scale = np.repeat(np.sqrt(weights), 6)
    if k == 0 or n_base == 0 or not np.any(scale > 0):
        return tau_id[n_base:].copy(), np.zeros(k)
    # f = D g with D = diag(√w): min ‖g‖ s.t. J_bᵀ D g = τ_b  ⇔  min Σ ‖f_i‖²/w_i.
    f = scale * (pinv(J_contacts[:, :n_base].T * scale) @ tau_id[:n_base])
    return tau_id[n_base:] - J_contacts[:, n_base:].T @ f, f


def zmp_from_wrenches(
    points: np.ndarray, forces: np.ndarray, torques: np.ndarray, min_force: float = 0.0
) -> np.ndarray:
    """ZMP on the plane z = 0 of wrenches applied by the ground.

    Args:
        points: (k, 3) application points [m]; forces: (k, 3) [N]; torques: (k, 3) [N·m]
            (pure moments besides the forces), all in the world frame.
        min_force: total vertical force [N] below which the ZMP is undefined.
    Returns:
        ``[x, y, f_z]``: the point where the total moment has no horizontal component,
        and the total vertical force; x = y = NaN when ``f_z < min_force``.
    """
    min_force = nonnegative("min_force", min_force, unit="N")
    f = forces.sum(axis=0)
    # The horizontal moment about the origin, Σ τ + Σ p × f (its x and y rows; np.cross costs
    # ~10-25 µs a call in numpy 2, four dot products ~4).
    x, y, z = points.T
    fx, fy, fz = forces.T
    n_x = torques[:, 0].sum() + y.dot(fz) - z.dot(fy)
    n_y = torques[:, 1].sum() + z.dot(fx) - x.dot(fz)
    if f[2] < max(min_force, 1e-9):
        return np.array([np.nan, np.nan, f[2]])
    return np.array([-n_y / f[2], n_x / f[2], f[2]])
