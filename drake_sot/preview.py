"""ZMP preview control on the cart-table model (Kajita et al. 2003).

Pure numpy/scipy; no Drake.

**Cart-table model** (Kajita et al., ICRA 2003).  Per horizontal axis the centre
of mass (CoM) at constant height ``z_c`` has state ``x = [c, ċ, c̈]`` and the
jerk ``u`` as input; the zero-moment point (ZMP) of the model is
``p = c - z_c/g · c̈``.  Discretised exactly at the period ``dt`` (jerk held
over a period)::

    x[k+1] = A x[k] + B u[k],   p[k] = C x[k]
    A = [[1, dt, dt²/2], [0, 1, dt], [0, 0, 1]],  B = [dt³/6, dt²/2, dt],  C = [1, 0, -z_c/g]

The same one-axis model drives x and y independently: every array below has
one column per axis.

**Preview servo** (Katayama's optimal preview servo, as used by Kajita).  The
augmented state ``[e[k], Δx[k]]`` with ``e = p - p_ref`` and ``Δx[k] = x[k] -
x[k-1]`` evolves with ``Ã = [[1, C A], [0, A]]``, ``B̃ = [C B, B]``; the cost
``Σ q e² + r Δu²`` gives the Riccati solution ``P̃`` (``scipy.linalg.
solve_discrete_are``) and the gains ``[Gi, Gx] = (r + B̃ᵀP̃B̃)⁻¹ B̃ᵀ P̃ Ã``.
Summed over time the optimal increment becomes the control law::

    u[k] = -Gi Σ_{i≤k} e[i] - Gx x[k] - Σ_{j=1}^{N-1} G(j) p_ref[k+j]
    G(1) = -Gi,   G(j) = (r + B̃ᵀP̃B̃)⁻¹ B̃ᵀ X̃(j-1),   X̃(1) = -Ãcᵀ P̃ Ĩ,   X̃(j) = Ãcᵀ X̃(j-1)

with ``Ãc = Ã - B̃ [Gi, Gx]`` (:attr:`PreviewController.closed_loop`) and ``Ĩ =
[1, 0, 0, 0]``.  The preview window handed to :meth:`PreviewController.step`
holds the ``N = round(horizon/dt)`` references ``p_ref[k], ..., p_ref[k+N-1]``;
``Gp[j]`` is the gain on ``p_ref[k+j]``: ``Gp[0] = -Gi`` is the current
sample's reference as it enters through the error integral, and ``Gp[j] =
G(j)`` for ``j ≥ 1``.  With this bookkeeping the law reads
``u = -Gi s - Gx x - Gi C x - Gp · window``, ``s`` the error sum of the past samples.

The error sum also carries the history of the jerk (the law is the sum of optimal
*increments*), and the truncated preview sum is not translation invariant
(``Gx[0] + Σ_{j≥1} Gp[j]`` is small but not zero: 292 m/s³ per metre against
``Gx[0] ≈ 7.3e4`` with the defaults).  A start from ``s = 0`` therefore kicks the
jerk unless the CoM is at rest at the origin under a constant window;
:meth:`PreviewController.initial_error_sum` gives the bumpless starting value
(zero jerk on the sample before the start), and :meth:`PreviewController.plan`
uses it by default.

**Offline CoM of a ZMP reference.**  :meth:`PreviewController.plan` runs the servo
over a whole reference sampled at ``dt`` and returns the CoM position, velocity and
acceleration, and the model's ZMP, of every sample (:class:`PreviewPlan`): the CoM
trajectory that realises a walk's ZMP reference, before anything runs.  The footsteps
that make such a reference are :mod:`drake_sot.walk_planner` (its ``FootstepPlan.sample``);
tutorials/02_walking_pattern.py shows the two together.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from drake_sot import kernels, validation

__all__ = ["PreviewController", "PreviewPlan"]

# --------------------------------------------------------------------------- preview control


@dataclass(frozen=True, eq=False)
class PreviewPlan:
    """Result of :meth:`PreviewController.plan`: per sample ``k`` (time ``k·dt``) and axis (x, y).

    Attributes:
        com: (K, 2) CoM position [m].
        com_vel: (K, 2) CoM velocity [m/s].
        com_acc: (K, 2) CoM acceleration [m/s²].
        zmp: (K, 2) the model's ZMP ``C x = com - z_c/g · com_acc`` [m].
    """

    com: np.ndarray
    com_vel: np.ndarray
    com_acc: np.ndarray
    zmp: np.ndarray

    def __len__(self) -> int:
        return len(self.com)


class PreviewController:
    """Cart-table ZMP preview control, discretised at ``dt``, one axis model applied to x and y.

    Args:
        dt: sampling period [s].
        z_c: CoM height of the cart-table model [m].
        horizon: preview time [s]; ``N = round(horizon/dt)`` references are previewed
            (the current one and the ``N - 1`` next ones).
        q: weight of the squared ZMP error.
        r: weight of the squared jerk increment.
        g: gravity [m/s²].

    Attributes:
        dt, z_c, horizon, q, r, g: the arguments.
        N: number of previewed samples.
        A: (3, 3), B: (3,), C: (3,) the discrete cart-table model.
        Gi: integral gain (scalar).
        Gx: (3,) state gain.
        Gp: (N,) preview gains, ``Gp[j]`` on the reference ``j`` samples ahead (``Gp[0] = -Gi``;
            see the module docstring).
        P: (4, 4) Riccati solution of the integral-augmented system.
        closed_loop: (4, 4) ``Ã - B̃ [Gi, Gx]``, the closed loop of the augmented system.
    """

    def __init__(
        self,
        dt: float = 0.005,
        z_c: float = 0.814,
        horizon: float = 1.6,
        q: float = 1.0,
        r: float = 1e-6,
        g: float = 9.81,
    ) -> None:
        self.dt = validation.positive("dt", dt, unit="s")
        self.z_c = validation.positive("z_c", z_c, unit="m")
        self.horizon = validation.positive("horizon", horizon, unit="s")
        self.q = validation.positive("q", q)
        self.r = validation.positive("r", r)
        self.g = validation.positive("g", g, unit="m/s²")
        self.N = round(self.horizon / self.dt)
        if self.N < 2:
            raise ValueError(
                f"horizon = {horizon!r} s: must cover at least 2 samples of dt = {dt!r} s (N = {self.N})"
            )
        T = self.dt
        self.A = np.array([[1.0, T, T * T / 2.0], [0.0, 1.0, T], [0.0, 0.0, 1.0]])
        self.B = np.array([T**3 / 6.0, T * T / 2.0, T])
        self.C = np.array([1.0, 0.0, -self.z_c / self.g])

        # Integral-augmented system [e, Δx].
        At = np.zeros((4, 4))
        At[0, 0] = 1.0
        At[0, 1:] = self.C @ self.A
        At[1:, 1:] = self.A
        Bt = np.concatenate([[self.C @ self.B], self.B])[:, None]
        Qt = np.zeros((4, 4))
        Qt[0, 0] = self.q
        Rt = np.array([[self.r]])
        P = scipy.linalg.solve_discrete_are(At, Bt, Qt, Rt)
        denom = float(self.r + Bt[:, 0] @ P @ Bt[:, 0])
        K = (Bt[:, 0] @ P @ At) / denom  # [Gi, Gx]
        self.P = P
        self.Gi = float(K[0])
        self.Gx = K[1:].copy()
        self.closed_loop = At - Bt @ K[None, :]

        # Preview gains: Gp[0] = -Gi (current reference, via the integral), then G(1..N-1).
        Gp = np.empty(self.N)
        Gp[0] = -self.Gi
        Gp[1] = -self.Gi
        Act = self.closed_loop.T
        X = -Act @ P[:, 0]
        for j in range(2, self.N):
            Gp[j] = (Bt[:, 0] @ X) / denom
            X = Act @ X
        self.Gp = Gp
        # step(): u = -(Gi s + Kx x + Gp·window) with Kx = Gx + Gi C.  One (5, 4+N) matrix
        # maps [x; s; window] to [x_next; s_next; zmp] (the whole tick is one product).
        Kx = self.Gx + self.Gi * self.C
        tick = np.zeros((5, 4 + self.N))
        tick[:3, :3] = self.A - np.outer(self.B, Kx)
        tick[:3, 3] = -self.Gi * self.B
        tick[:3, 4:] = -np.outer(self.B, self.Gp)
        tick[3, :3] = self.C
        tick[3, 3] = 1.0
        tick[3, 4] = -1.0
        tick[4, :3] = self.C
        self._tick = tick
        self._Ainv = np.linalg.inv(self.A)

    def step(
        self, x: np.ndarray, error_sum: np.ndarray, preview: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One online tick, for both axes at once.

        Inputs are not checked (this runs every control period); :meth:`plan` checks them.

        Args:
            x: (3, 2) current state ``[c, ċ, c̈]`` per axis.
            error_sum: (2,) sum of ``zmp - zmp_ref`` over the past samples, starting from
                :meth:`initial_error_sum` (not from zeros: see the module docstring).
            preview: (N, 2) ZMP references of the current sample and the ``N - 1`` next ones.

        Returns:
            ``(x_next (3, 2), error_sum_next (2,), zmp (2,))`` where ``zmp = C x`` is the
            model ZMP of the current state and ``error_sum_next = error_sum + zmp - preview[0]``.
        """
        if kernels.compiled is not None:  # the same product as step_at's and plan's, bit for bit
            return kernels.compiled.preview_step_at(self._tick, x, error_sum, preview, 0)
        return self.step_numpy(x, error_sum, preview)

    def step_numpy(
        self, x: np.ndarray, error_sum: np.ndarray, preview: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`step` in numpy: the compiled kernel's oracle and fallback."""
        out = self._tick @ np.concatenate((x, error_sum[None], preview))
        return out[:3], out[3], out[4]

    def step_at(
        self, x: np.ndarray, error_sum: np.ndarray, reference: np.ndarray, k: int
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`step` over the window of samples ``k`` to ``k + N - 1`` of ``reference`` (K, 2)
        (:meth:`window`: its last sample held past its end), without building the window where the
        compiled kernel runs (:mod:`drake_sot.kernels`; this numpy path is its oracle)."""
        if kernels.compiled is not None:
            return kernels.compiled.preview_step_at(self._tick, x, error_sum, reference, k)
        return self.step_numpy(x, error_sum, self.window(reference, k))

    def initial_error_sum(self, x0: np.ndarray, preview: np.ndarray) -> np.ndarray:
        """(2,) error sum that starts :meth:`step` without a kick (a bumpless start).

        The summed control law carries the history of the jerk in the error sum.  This
        value makes the jerk of the sample before the start zero, as if the state ``x0``
        (3, 2) had been reached from ``A⁻¹ x0`` with no jerk while the window, shifted back
        one sample, was ``[preview[0], preview[0], ..., preview[N-2]]``.  At rest over a
        constant reference ``p0`` it is ``-(Gx[0] + Σ_{j≥1} Gp[j]) p0 / Gi``, the integral
        action that cancels the truncation of the preview sum, and the CoM stays put.

        Args:
            x0: (3, 2) state at the start.
            preview: (N, 2) the window of the first sample.
        """
        x_prev = self._Ainv @ x0
        return -(self.Gx @ x_prev + self.Gp[1:] @ preview[:-1]) / self.Gi

    def run_numpy(
        self, reference: np.ndarray, x: np.ndarray, error_sum: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """:meth:`plan`'s loop in numpy (the compiled kernel's oracle and fallback): the state
        (K, 3, 2) before each sample of ``reference`` (K, 2) from ``x`` (3, 2) and ``error_sum``
        (2,), and the model ZMP (K, 2) of each."""
        K = reference.shape[0]
        states = np.empty((K, 3, 2))
        zmp = np.empty((K, 2))
        step, window = self.step_numpy, self.window
        for k in range(K):
            states[k] = x
            x, error_sum, zmp[k] = step(x, error_sum, window(reference, k))
        return states, zmp

    def window(self, reference: np.ndarray, k: int) -> np.ndarray:
        """(N, 2): the references of samples ``k`` to ``k + N - 1``, the last sample of
        ``reference`` (K, 2) held past its end (a plan ends standing still)."""
        window = reference[k : k + self.N]
        if len(window) < self.N:
            window = np.concatenate((window, np.repeat(reference[-1:], self.N - len(window), axis=0)))
        return window

    def plan(
        self,
        zmp_reference: np.ndarray,
        x0: np.ndarray | None = None,
        error_sum: np.ndarray | None = None,
    ) -> PreviewPlan:
        """The CoM trajectory that realises a ZMP reference, computed offline.

        Runs :meth:`step` over the whole reference, each sample previewing the ``N - 1``
        next ones (the last value held past the end: :meth:`window`). This is what a
        walking pattern generator does online, done at once for a known walk: hand it
        the ZMP reference of a footstep plan (``drake_sot.walk_planner.FootstepPlan.sample``)
        and check the CoM, or the model ZMP against the support polygon, before running
        anything (tutorials/02_walking_pattern.py). Start the reference with about one
        preview time of standing still: a CoM at rest cannot anticipate a ZMP transfer it
        has not seen.

        Args:
            zmp_reference: (K, 2) reference [m] sampled at ``dt``.
            x0: (3, 2) initial ``[c, ċ, c̈]`` per axis [m, m/s, m/s²]; default at rest over
                ``zmp_reference[0]``.
            error_sum: (2,) initial error sum; default :meth:`initial_error_sum` (bumpless).

        Returns:
            A :class:`PreviewPlan` of K samples, sample ``k`` being the state at time ``k·dt``.
        """
        ref = validation.matrix("zmp_reference", zmp_reference, (None, 2))
        if ref.shape[0] < 1:
            raise ValueError("zmp_reference must have at least one sample, got shape (0, 2)")
        if x0 is None:
            x = np.zeros((3, 2))
            x[0] = ref[0]
        else:
            x = validation.matrix("x0", x0, (3, 2))
        s = (
            self.initial_error_sum(x, self.window(ref, 0))
            if error_sum is None
            else validation.vector("error_sum", error_sum, 2)
        )
        if kernels.compiled is not None:
            rows, zmp = kernels.compiled.preview_plan(self._tick, ref, x, s)
            states = rows.reshape(-1, 3, 2)
        else:
            states, zmp = self.run_numpy(ref, x, s)
        return PreviewPlan(
            com=states[:, 0].copy(),
            com_vel=states[:, 1].copy(),
            com_acc=states[:, 2].copy(),
            zmp=zmp,
        )
