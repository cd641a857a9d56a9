"""Balance stabilization by divergent-component-of-motion (DCM) feedback. Pure numpy.

Notation (ground-plane quantities are (2,) [m], world frame):
    c, ċ       CoM position and velocity of the robot (measured on the simulated plant);
    c_r, ċ_r   their references (the pattern generator's cart-table CoM);
    p, p_r     measured ZMP (ankle force sensors) and reference ZMP;
    ω          natural frequency of the linear inverted pendulum, ω = sqrt(g / z_c) [1/s].

Why DCM feedback (Englsberger, Ott, Albu-Schäffer 2015) rather than the LIPM tracking of
Kajita et al. 2010. The LIPM  c̈ = ω² (c − p)  splits into a stable part, which converges by
itself, and the divergent component

    ξ = c + ċ / ω,          ξ̇ = ω (ξ − p),                                    (1)

the only one the ZMP has to act on (Englsberger et al. 2015, eq. 4-8). A push is a jump of ċ,
hence of ξ by Δv / ω; the robot can stop without a step only while ξ stays where the ZMP can
reach, inside the support polygon. Feeding back the DCM error with the reference
ξ̇_r = ω (ξ_r − p_r) gives the desired ZMP

    p_d = p_r + (1 + k_ξ / ω) (ξ − ξ_r),                                       (2)

with which (1) becomes  d(ξ − ξ_r)/dt = −k_ξ (ξ − ξ_r):  the error decays at the rate k_ξ
one chooses (their eq. 11 with the virtual repellent point on the ground). Kajita et al.
2010 place the poles of the full state (c, ċ, p) of the LIPM with a ZMP lag; its first
stage is equivalent (a state feedback on c and ċ), but it realises p_d through ankle torque
control of each foot (foot force and damping control), which a position-controlled robot
driven by a kinematic Stack of Tasks does not have: here every joint tracks a reference
posture. DCM feedback keeps one gain with a physical meaning (the decay rate of ξ), needs
only c, ċ and p, and tells directly when a push cannot be rejected: p_d outside the
support polygon.

Realising p_d through the CoM reference. The SoT resolves the motion at the velocity level
on a position-controlled robot, so p_d is obtained by correcting the CoM reference sent to
the CoM task by an offset Δc, driven by the ZMP error as a CoM admittance (as the CoM
admittance control of Caron et al. 2019 does on HRP-4):

    Δc̈ = −k_z (p_d − p̄) − d Δċ,                                                (3)

p̄ being the measured ZMP low-passed with the time constant τ; below the frequency d the
offset moves at Δċ ≈ −(k_z / d) (p_d − p̄), the ZMP tracking law of the kinematic CoM
controller of Choi et al. 2007. When the measured ZMP lags behind the desired one, the CoM
reference decelerates and c̈ = ω² (c − p) puts the ZMP forward; when the stiff posture
control pushes the ZMP beyond p_d (towards a sole edge, where the foot would roll), the
reference yields to the push. The offset is driven through its acceleration, not its
velocity, because Δċ reaches the CoM task as a velocity feed-forward: a velocity
proportional to a (noisy) ZMP error would jump at every tick, and the inverse-dynamics
torque feed-forward of the reference acceleration would kick the robot. With a robot that
tracks its reference (c = c_r + Δc, p = c − c̈ / ω²), (2) and (3)
give at rest

    (1 + k_z / ω²) Δc̈ + (d + k_z (1 + k_ξ / ω) / ω) Δċ + (k_z k_ξ / ω) Δc = 0,

stable for every k_ξ, k_z > 0, d >= 0: the offset returns to zero once the disturbance is
gone (with the default gains, at the CoM height of the embedded humanoid, ω = 3.5 /s: a
natural frequency of 2.5 rad/s, overdamped).

External wrenches at the hands (Evrard et al. 2009, III-D: the interaction forces of a
collaborative task perturb the ZMP). The LIPM above has no external force; a robot carrying
an object with a partner has one at each hand, (τ_i, f_i) at the point h_i (world axes; the
wrench the object applies on the robot, measured by the wrist sensors). At the ZMP p the
forces on the robot other than the ground's, gravity m g at c, the inertial force −m c̈
(c̈_z = 0 and the rate of angular momentum about the CoM neglected, as in the LIPM) and the
hands' wrenches, have no horizontal moment. The moments about the ground point p, per axis:

    (m g − f_z) p = m g (c − c̈ / ω²) + Σ_i (z_i f_i,xy − f_i,z h_i,xy + S τ_i),          (4)

with f_z = Σ_i f_i,z, z_i the height of h_i above the ground and S (τ_x, τ_y) = (τ_y, −τ_x).
Without the hands it is the LIPM's p = c − c̈ / ω²; a forward pull f_x at the height z_h moves
the ZMP forward by z_h f_x / (m g) (15 N at 0.84 m on the 57.8 kg embedded humanoid: 2.2 cm),
a load carried in front (f_z < 0, h_x ahead) too. Solved for c̈, (4) is the LIPM with the
moved ZMP  p_h(p) = ((m g − f_z) p − Σ_i (...)) / (m g):

    c̈ = ω² (c − p_h(p)),        ξ̇ = ω (ξ − p_h(p)).                                        (5)

The pattern generator planned the free LIPM, ξ̇_r = ω (ξ_r − p_r); the robot follows the plan
when p_h(p) = p_r, i.e. with the ZMP (4) gives for the planned motion (c_r − c̈_r / ω² = p_r):

    p_r^h = (m g p_r + Σ_i (z_i f_i,xy − f_i,z h_i,xy + S τ_i)) / (m g − f_z),            (6)

and the DCM feedback (2), for the error to decay at k_ξ again under (5), becomes

    p_d = p_r^h + (1 + k_ξ / ω) (m g / (m g − f_z)) (ξ − ξ_r).                             (2')

Without (6) the measured ZMP sits ahead of p_d by p_r^h − p_r under a forward pull, and (3)
reads it as the ZMP of a robot falling back: the offset drives the CoM forward, towards the
pull (``benchmarks/README.md``: the tele-cooperation walk with the co-operator leading). With it
the ZMP the hands cause is expected, and the offset answers
only the DCM error. :class:`HandLoad` holds the wrenches; :func:`stabilizer_step` takes it.

Limits, never silent: p_d is projected into the support polygon (shrunk by a margin) when
(2) puts it outside, and Δc is bounded per axis; :class:`StabilizerStep` says when either
happened. A DCM outside the polygon cannot be brought back through the ZMP: that needs
angular momentum (rotating the trunk, the hip strategy: :mod:`drake_sot.recovery`, fed by
the stabilizer's ``dcm_excess``) or a step; the stabilizer itself passes the waist and foot
references through unchanged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from drake_sot import kernels, validation

#: Standard gravity [m/s²] of the LIPM.
GRAVITY = 9.81


@dataclass(frozen=True)
class StabilizerGains:
    """Gains and limits of the DCM stabilizer.

    Attributes:
        dcm: k_ξ [1/s], the decay rate of the DCM error (eq. 2), finite and > 0.
        zmp: k_z [1/s²], the ZMP gain of the CoM offset's acceleration (eq. 3), finite and > 0.
        damping: d [1/s], damping of the CoM offset's rate (eq. 3), >= 0.
        zmp_filter: τ [s], time constant of the low-pass filter of the measured ZMP, >= 0
            (0: no filter).
        wrench_filter: τ_h [s], time constant of the low-pass filter of the hands' measured
            wrenches (eq. 4-6), >= 0 (0: no filter). Eq. 6 is the LIPM's answer to the slow
            interaction (a partner's pull, an object's weight); the faster part of the measured
            wrench is the robot's own stepping shaking the object, and fed through it closed a
            loop that shook the co-operator-led tele-cooperation walk until the robot fell (15 s
            in, with the wrench's standard deviation growing from 1 to 10 N): that part is left
            to the DCM feedback.
        max_offset: [m] bound of the CoM offset |Δc| on each ground axis, finite and > 0.
        margin: [m] the desired ZMP is kept this far inside the support polygon, >= 0.

    Raises:
        ValueError: a value out of its range, named.
    """

    dcm: float = 3.0
    zmp: float = 20.0
    damping: float = 10.0
    zmp_filter: float = 0.02
    wrench_filter: float = 1.0
    max_offset: float = 0.10
    margin: float = 0.01

    def __post_init__(self) -> None:
        for name, unit in (("dcm", "1/s"), ("zmp", "1/s²"), ("max_offset", "m")):
            object.__setattr__(self, name, validation.positive(name, getattr(self, name), unit=unit))
        for name, unit in (
            ("damping", "1/s"),
            ("zmp_filter", "s"),
            ("wrench_filter", "s"),
            ("margin", "m"),
        ):
            object.__setattr__(self, name, validation.nonnegative(name, getattr(self, name), unit=unit))


def natural_frequency(com_height: float, gravity: float = GRAVITY) -> float:
    """ω = sqrt(g / z_c) [1/s] of the linear inverted pendulum of height ``com_height`` [m]."""
    com_height = validation.positive("com_height", com_height, unit="m")
    return math.sqrt(validation.positive("gravity", gravity, unit="m/s²") / com_height)


def divergent_component(com: np.ndarray, com_vel: np.ndarray, omega: float) -> np.ndarray:
    """ξ = c + ċ / ω (eq. 1) [m], on as many axes as ``com`` has; ``omega`` [1/s] in
    [:data:`OMEGA_BOUNDS`] (:func:`natural_frequency`), ``com`` [m] and ``com_vel`` [m/s] finite,
    of one length; ValueError naming what is not, or a ξ beyond float range."""
    omega = validation.bounded("omega", omega, *OMEGA_BOUNDS, unit="1/s")
    com = validation.vector("com", com)
    with np.errstate(over="ignore"):
        xi = com + validation.vector("com_vel", com_vel, com.shape[0]) / omega
    if not np.all(np.isfinite(xi)):
        raise ValueError(
            f"divergent component of com = {com}, com_vel = {com_vel}, omega = {omega:g}: not finite"
        )
    return xi


#: The natural frequencies [1/s] of a pendulum between 1 km and 1 mm tall (sqrt(g / z_c)): a
#: humanoid's is about 3.5.
OMEGA_BOUNDS = (1e-3, 1e3)


#: The largest coordinate [m] of a support polygon's vertex or of a point projected into it: far
#: beyond any walk, small enough that the products of the projection cannot overflow.
COORDINATE_BOUND = 1e6


def project_into_polygon(polygon: np.ndarray, point: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """The point of a convex polygon, shrunk by ``margin`` [m], nearest to ``point`` (2,).

    Args:
        polygon: (k, 2) vertices of a convex polygon in order (``support.support_polygon``),
            k >= 3, counter-clockwise or clockwise (read in the reverse order); a vertex
            repeated or in line with its neighbours is dropped.
        point: (2,) [m].
        margin: [m] >= 0, smaller than the polygon's inradius.

    Raises:
        ValueError: the polygon has fewer than 3 vertices (not in line) or is not convex (naming
            the vertex); the polygon shrunk by ``margin`` is empty (named with the margin).

    The compiled kernel computes it where built (:mod:`drake_sot.kernels`, the same checks);
    :func:`project_into_polygon_numpy` is its oracle and fallback, and names what the kernel cannot
    take (a shape, a type).
    """
    if kernels.compiled is not None:
        try:
            return kernels.compiled.project_into_polygon(polygon, point, margin)
        except TypeError:  # not arrays of floats of the shapes above: the numpy path names what
            pass
    return project_into_polygon_numpy(polygon, point, margin)


def project_into_polygon_numpy(polygon: np.ndarray, point: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """:func:`project_into_polygon` in numpy: the compiled kernel's oracle and fallback."""
    polygon = validation.matrix("polygon", polygon, (None, 2))
    point = validation.magnitude("point", point, COORDINATE_BOUND, 2, unit="m")
    margin = validation.nonnegative("margin", margin, unit="m")
    polygon = _convex_counter_clockwise(polygon)
    edge = _next(polygon) - polygon
    normal = np.stack((-edge[:, 1], edge[:, 0]), axis=1) / np.linalg.norm(edge, axis=1, keepdims=True)
    offset = np.einsum("ij,ij->i", normal, polygon) + margin  # inside: normal · x >= offset
    if np.all(normal @ point >= offset):
        return point
    # Vertices of the shrunk polygon: edge i-1 and edge i, each moved inward by the margin, met
    # (the 2x2 systems [n_{i-1}; n_i] x = [o_{i-1}; o_i] of all vertices at once, by Cramer's rule).
    before, offset_before = _previous(normal), _previous(offset)
    det = before[:, 0] * normal[:, 1] - before[:, 1] * normal[:, 0]
    vertices = np.stack(
        (
            (offset_before * normal[:, 1] - before[:, 1] * offset) / det,
            (before[:, 0] * offset - offset_before * normal[:, 0]) / det,
        ),
        axis=1,
    )
    if np.any(normal @ vertices.T < offset[:, None] - 1e-9):
        raise ValueError(f"margin = {margin!r} m: larger than the support polygon's inradius")
    # The nearest point of each edge of the shrunk polygon, then the nearest of those (the first
    # one on a tie).
    ab = _next(vertices) - vertices
    length2 = np.einsum("ij,ij->i", ab, ab)
    along = np.einsum("ij,ij->i", point - vertices, ab)
    s = np.clip(np.divide(along, length2, out=np.zeros_like(along), where=length2 > 0.0), 0.0, 1.0)
    candidates = vertices + s[:, None] * ab
    gap = point - candidates
    return candidates[int(np.argmin(np.einsum("ij,ij->i", gap, gap)))]


def _convex_counter_clockwise(polygon: np.ndarray) -> np.ndarray:
    """``polygon`` (k, 2) as a convex polygon's vertices in counter-clockwise order: a clockwise
    one reversed; a vertex that repeats the one before it, or lies in line with its two
    neighbours (to a relative :data:`_IN_LINE`), dropped (the polygon is the same set of points).

    Raises:
        ValueError: fewer than 3 vertices (or left once those are dropped), a coordinate beyond
            ±:data:`COORDINATE_BOUND`, turns both ways (not convex, or not in order), naming
            the vertex.
    """
    if polygon.shape[0] < 3:
        raise ValueError(f"polygon has {polygon.shape[0]} vertices: a support polygon needs at least 3")
    if not np.max(np.abs(polygon)) <= COORDINATE_BOUND:
        raise ValueError(f"polygon: a coordinate beyond ±{COORDINATE_BOUND:g} m")
    given = polygon
    while True:
        edge = polygon - _previous(polygon)  # edge i ends at vertex i
        scale = float(np.max(np.abs(edge)))
        if polygon.shape[0] < 3 or not scale > 0.0:
            raise ValueError(
                f"polygon {given.tolist()}: fewer than 3 vertices once those repeated or in line are dropped"
            )
        unit = edge / scale  # the turn at each vertex, scaled: no overflow, a tolerance relative
        turn = unit[:, 0] * _next(unit)[:, 1] - unit[:, 1] * _next(unit)[:, 0]
        flat = np.abs(turn) <= _IN_LINE
        if not flat.any():
            break
        polygon = np.delete(polygon, int(np.argmax(flat)), axis=0)
    if np.all(turn < 0.0):
        return polygon[::-1].copy()
    if not np.all(turn > 0.0):
        i = int(np.argmin(turn)) if np.count_nonzero(turn > 0.0) > turn.size // 2 else int(np.argmax(turn))
        raise ValueError(
            f"polygon {given.tolist()}: turns both ways at vertex {polygon[i].tolist()}: the vertices must "
            "be a convex polygon's, in order"
        )
    return polygon


#: A vertex whose turn (the cross product of its two edges over the square of the longest edge)
#: is at most this is in line with its neighbours.
_IN_LINE = 1e-12


def _next(rows: np.ndarray) -> np.ndarray:
    """``rows`` turned by one: row i is row i + 1 (``np.roll(rows, -1, axis=0)``, ~5x cheaper)."""
    return np.concatenate((rows[1:], rows[:1]))


def _previous(rows: np.ndarray) -> np.ndarray:
    """``rows`` turned back by one: row i is row i - 1 (``np.roll(rows, 1, axis=0)``)."""
    return np.concatenate((rows[-1:], rows[:-1]))


def low_pass(filtered: np.ndarray, value: np.ndarray, dt: float, tau: float) -> np.ndarray:
    """One tick of ``dt`` [s] (finite, > 0) of a first-order low-pass filter of time constant
    ``tau`` [s] (finite, >= 0; 0 passes ``value`` through):
    ``filtered`` moved towards ``value`` by dt / (tau + dt) of the gap. ``filtered`` with NaN (no
    value yet): ``value`` as it is; ``value`` with NaN (no measurement): ``filtered`` as it was."""
    dt = validation.positive("dt", dt, unit="s")
    tau = validation.nonnegative("tau", tau, unit="s")
    value, filtered = np.asarray(value, dtype=float), np.asarray(filtered, dtype=float)
    if not np.all(np.isfinite(value)):
        return filtered
    if not np.all(np.isfinite(filtered)):
        return value
    return filtered + dt / (tau + dt) * (value - filtered)


@dataclass(frozen=True)
class HandLoad:
    """External wrenches on the robot at its hands, for the LIPM with external forces (eq. 4-6).

    Attributes:
        mass: m [kg], the robot's mass, finite and > 0.
        points: (k, 3) [m] the points h_i where the wrenches apply (the hand frames' origins),
            world frame, the ground at z = 0.
        wrenches: (k, 6) ``[τ_i [N m]; f_i [N]]`` the wrench the environment applies on the
            robot at h_i (torque about h_i), world axes.
        gravity: g [m/s²], finite and > 0.

    Raises:
        ValueError: a value out of its range or of the wrong shape, named; the hands carrying
            the robot's weight (m g − f_z <= 0: the feet have no load, hence no ZMP).
    """

    mass: float
    points: np.ndarray
    wrenches: np.ndarray
    gravity: float = GRAVITY

    def __post_init__(self) -> None:
        object.__setattr__(self, "mass", validation.positive("mass", self.mass, unit="kg"))
        object.__setattr__(self, "gravity", validation.positive("gravity", self.gravity, unit="m/s²"))
        points = validation.matrix("points", self.points, (None, 3))
        wrenches = validation.matrix("wrenches", self.wrenches, (len(points), 6))
        object.__setattr__(self, "points", points)
        object.__setattr__(self, "wrenches", wrenches)
        if not (self.weight - wrenches[:, 5].sum() > 0.0):
            raise ValueError(
                f"wrenches: the hands' vertical force {wrenches[:, 5].sum()!r} N carries the robot's "
                f"weight {self.weight!r} N (no load on the feet, no ZMP)"
            )

    @property
    def weight(self) -> float:
        """m g [N]."""
        return self.mass * self.gravity

    def moment(self) -> np.ndarray:
        """(2,) [N m] Σ_i (z_i f_i,xy − f_i,z h_i,xy + S τ_i), the hands' term of eq. 4."""
        tau, f, h = self.wrenches[:, :3], self.wrenches[:, 3:], self.points
        swapped = np.stack((tau[:, 1], -tau[:, 0]), axis=1)
        return np.sum(h[:, 2:3] * f[:, :2] - f[:, 2:3] * h[:, :2] + swapped, axis=0)

    def zmp(self, free_zmp: np.ndarray) -> np.ndarray:
        """(2,) [m] the ZMP (eq. 4) of a robot whose free LIPM's ZMP, c − c̈ / ω², is
        ``free_zmp`` (2,) [m]; with ``free_zmp`` = p_r it is the reference p_r^h of eq. 6."""
        free_zmp = np.asarray(free_zmp, dtype=float)
        return (self.weight * free_zmp + self.moment()) / (self.weight - self.wrenches[:, 5].sum())

    def feedback_scale(self) -> float:
        """m g / (m g − f_z), the factor of the DCM feedback in eq. 2'."""
        return self.weight / (self.weight - self.wrenches[:, 5].sum())


@dataclass(frozen=True)
class StabilizerStep:
    """The stabilizer's state after one control tick, and what it decided.

    Attributes:
        offset: Δc (2,) [m], the CoM reference offset.
        offset_rate: Δċ (2,) [m/s], its rate (the velocity feed-forward).
        zmp_filtered: p̄ (2,) [m], the low-passed measured ZMP.
        zmp_desired: p_d (2,) [m], eq. 2 after projection into the support polygon.
        zmp_saturated: eq. 2 put p_d outside the support polygon (it was projected).
        offset_saturated: the offset reached ``max_offset`` on an axis (it was held there,
            its rate set to zero on that axis).
    """

    offset: np.ndarray
    offset_rate: np.ndarray
    zmp_filtered: np.ndarray
    zmp_desired: np.ndarray
    zmp_saturated: bool
    offset_saturated: bool


def stabilizer_step(
    offset: np.ndarray,
    offset_rate: np.ndarray,
    zmp_filtered: np.ndarray,
    *,
    com_ref: np.ndarray,
    com_vel_ref: np.ndarray,
    zmp_ref: np.ndarray,
    com: np.ndarray,
    com_vel: np.ndarray,
    zmp: np.ndarray,
    polygon: np.ndarray,
    omega: float,
    dt: float,
    gains: StabilizerGains,
    hands: HandLoad | None = None,
) -> StabilizerStep:
    """Advance the stabilizer by one tick of ``dt`` [s] (eq. 2 and 3, semi-implicit Euler).

    All points are ground-plane (2,) [m] (velocities [m/s]); ``polygon`` is the support
    polygon (k, 2). ``offset``, ``offset_rate`` and ``zmp_filtered`` are the state before the
    tick (``zmp_filtered`` NaN: no measurement yet, the first one is taken as it is). A
    measured ``zmp`` with NaN (the feet carry no load: no ZMP) leaves the filtered ZMP as it
    was; while there is none, only the damping acts on the offset's rate. ``hands``: the
    external wrenches at the hands, the desired ZMP then from eq. 6 and 2' instead of 2
    (None: no external wrench, eq. 2).

    The compiled kernel computes it where built (:mod:`drake_sot.kernels`; the same checks, as
    ValueError); :func:`stabilizer_step_numpy` is its oracle and fallback.
    """
    if kernels.compiled is not None:
        try:
            return _stabilizer_step_compiled(
                offset,
                offset_rate,
                zmp_filtered,
                com_ref,
                com_vel_ref,
                zmp_ref,
                com,
                com_vel,
                zmp,
                polygon,
                omega,
                dt,
                gains,
                hands,
            )
        except TypeError:  # not arrays of floats of the shapes above: the numpy path names what
            pass
    return stabilizer_step_numpy(
        offset,
        offset_rate,
        zmp_filtered,
        com_ref=com_ref,
        com_vel_ref=com_vel_ref,
        zmp_ref=zmp_ref,
        com=com,
        com_vel=com_vel,
        zmp=zmp,
        polygon=polygon,
        omega=omega,
        dt=dt,
        gains=gains,
        hands=hands,
    )


def _stabilizer_step_compiled(
    offset: np.ndarray,
    offset_rate: np.ndarray,
    zmp_filtered: np.ndarray,
    com_ref: np.ndarray,
    com_vel_ref: np.ndarray,
    zmp_ref: np.ndarray,
    com: np.ndarray,
    com_vel: np.ndarray,
    zmp: np.ndarray,
    polygon: np.ndarray,
    omega: float,
    dt: float,
    gains: StabilizerGains,
    hands: HandLoad | None,
) -> StabilizerStep:
    """:func:`stabilizer_step` by the compiled kernel (TypeError for what it cannot take)."""
    if hands is None:
        base, scale = zmp_ref, 1.0
    else:
        base, scale = hands.zmp(zmp_ref), hands.feedback_scale()
    offset, rate, filtered, desired, zmp_saturated, offset_saturated = kernels.compiled.stabilizer_step(
        offset,
        offset_rate,
        zmp_filtered,
        com_ref,
        com_vel_ref,
        base,
        com,
        com_vel,
        zmp,
        polygon,
        omega,
        dt,
        scale,
        gains.dcm,
        gains.zmp,
        gains.damping,
        gains.zmp_filter,
        gains.max_offset,
        gains.margin,
    )
    return StabilizerStep(
        offset=offset,
        offset_rate=rate,
        zmp_filtered=filtered,
        zmp_desired=desired,
        zmp_saturated=zmp_saturated,
        offset_saturated=offset_saturated,
    )


def stabilizer_step_numpy(
    offset: np.ndarray,
    offset_rate: np.ndarray,
    zmp_filtered: np.ndarray,
    *,
    com_ref: np.ndarray,
    com_vel_ref: np.ndarray,
    zmp_ref: np.ndarray,
    com: np.ndarray,
    com_vel: np.ndarray,
    zmp: np.ndarray,
    polygon: np.ndarray,
    omega: float,
    dt: float,
    gains: StabilizerGains,
    hands: HandLoad | None = None,
) -> StabilizerStep:
    """:func:`stabilizer_step` in numpy: the compiled kernel's oracle and fallback."""
    dcm_error = divergent_component(com, com_vel, omega) - divergent_component(com_ref, com_vel_ref, omega)
    if hands is None:
        raw = np.asarray(zmp_ref, dtype=float) + (1.0 + gains.dcm / omega) * dcm_error
    else:
        raw = hands.zmp(zmp_ref) + (1.0 + gains.dcm / omega) * hands.feedback_scale() * dcm_error
    desired = project_into_polygon_numpy(polygon, raw, gains.margin)
    zmp, filtered = np.asarray(zmp, dtype=float), np.asarray(zmp_filtered, dtype=float)
    filtered = low_pass(filtered, zmp, dt, gains.zmp_filter)
    rate = np.asarray(offset_rate, dtype=float)
    pull = -gains.zmp * (desired - filtered) if np.all(np.isfinite(filtered)) else np.zeros(2)
    rate = rate + (pull - gains.damping * rate) * dt
    moved = np.asarray(offset, dtype=float) + rate * dt
    bounded = np.clip(moved, -gains.max_offset, gains.max_offset)
    held = bounded != moved
    return StabilizerStep(
        offset=bounded,
        offset_rate=np.where(held, 0.0, rate),
        zmp_filtered=filtered,
        zmp_desired=desired,
        zmp_saturated=not np.array_equal(desired, raw),
        offset_saturated=bool(held.any()),
    )
