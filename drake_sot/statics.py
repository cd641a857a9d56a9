"""Quasi-static equilibrium of a floating-base robot in contact. Pure numpy.

Equation of motion at rest: ``0 = τ_g + Sᵀ τ + J_cᵀ f`` with ``τ_g`` the generalized
gravity forces (nv,), ``S`` the actuated-joint selection and ``J_c`` the stacked
contact Jacobians (k, nv). The base rows (no actuation) fix the contact wrenches up
to the internal ones; the joint rows then give the torques that hold the posture.
"""

from __future__ import annotations

import numpy as np

from drake_sot.linalg import pinv


def static_torques(tau_g: np.ndarray, J_contacts: np.ndarray, n_base: int = 6) -> tuple[np.ndarray, np.ndarray]:
    """Joint torques holding a floating-base robot at rest on its contacts.

    The contact wrenches are the minimum-norm solution of the base equilibrium
    ``τ_g[:n_base] + J_c[:, :n_base]ᵀ f = 0`` (no internal squeeze between contacts);
    with no contact (``J_contacts`` of 0 rows) the base is unsupported and only the
    joint gravity torques are returned.

    Args:
        tau_g: generalized gravity forces (nv,) (Drake's ``CalcGravityGeneralizedForces``).
        J_contacts: stacked contact Jacobians (k, nv).
        n_base: number of unactuated base velocities (6 for a free flyer, 0 for a fixed base).
    Returns:
        ``(τ (nv - n_base,) [N·m], f (k,))``: joint torques and contact wrenches.
    """
    if J_contacts.shape[0] == 0 or n_base == 0:
        return -tau_g[n_base:], np.zeros(J_contacts.shape[0])
    f = -pinv(J_contacts[:, :n_base].T) @ tau_g[:n_base]
    return -(tau_g[n_base:] + J_contacts[:, n_base:].T @ f), f
