"""The strict hierarchy of equalities and inequalities (Escande, Mansard, Wieber 2014):
:func:`solve_hqp`, the primal active set that solves it level by level in the null-space basis
form of :func:`drake_sot.hierarchy.solve_strict` (Mansard et al. 2009, eq. 8-9), and the
per-level reports of its result.

Level k holds rows ``l_k <= J_k q̇ <= u_k`` (``l = u`` for an equality); each level minimises
its slack given the levels above, then a last level ``I q̇ = 0`` picks the minimum-norm q̇.

The active set never gives up: on a degenerate point it turns to Bland's smallest-index rule,
and a last-resort guard returns the iterate it reached, naming the level
(:attr:`HqpResult.unsettled`), rather than raising. A control loop passes the last tick's
result as ``warm_start``: when the same rows are at a bound, the tick is one equality solve.

Two implementations of one solver: the compiled one (``drake_sot/kernels/hqp.cpp``, Eigen, no
BLAS, the GIL released), which :func:`solve_hqp` calls when the compiled kernels are loaded
(:mod:`drake_sot.kernels`), and the numpy one below (:func:`_solve_numpy`), its oracle and its
fallback. They take the same decisions and agree to rounding (``tests/test_kernels_hqp.py``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np
import scipy.linalg.lapack

from drake_sot import kernels, validation
from drake_sot.linalg import SvdSplit, _upper_mask, full_rank_lstsq
from drake_sot.validation import nonnegative

__all__ = [
    "HqpLevel",
    "HqpResult",
    "LevelReport",
    "TOLERANCE",
    "bound_sides",
    "level_report",
    "solve_hqp",
]


#: One level of :func:`solve_hqp`: ``(J, target)`` for equalities ``J q̇ = target``, or
#: ``(J, lower, upper)`` for ``lower <= J q̇ <= upper`` row by row (``lower == upper``
#: makes a row an equality, ``±inf`` drops a side).
HqpLevel = tuple[np.ndarray, np.ndarray] | tuple[np.ndarray, np.ndarray, np.ndarray]

#: :func:`solve_hqp`'s default tolerance: a row within it of a bound is at that bound.
TOLERANCE = 1e-9

_INF = math.inf
_EPS = float(np.finfo(float).eps)
_GEQRF = scipy.linalg.lapack.dgeqrf
_ORGQR = scipy.linalg.lapack.dorgqr
_TRTRI = scipy.linalg.lapack.dtrtri
_TRTRS = scipy.linalg.lapack.dtrtrs


@functools.cache
def _diagonal_blocks(sizes: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """``(starts, mask)``: where each block of the given sizes starts, and the (M, M) mask
    (Fortran order) of the upper triangles of the diagonal blocks."""
    level = np.repeat(np.arange(len(sizes)), sizes)
    mask = np.asfortranarray(np.triu((level[:, None] == level[None, :]).astype(float)))
    return np.cumsum([0, *sizes[:-1]]), mask


@dataclass(frozen=True)
class LevelReport:
    """How one level of :func:`solve_hqp` ended, at the final q̇.

    Attributes:
        name: the caller's name for the level (its index when the caller gave none).
        slack: (m,) ``v = J q̇ - clip(J q̇, lower, upper)``: zero on a row that holds,
            otherwise the signed amount by which it is violated (positive above its
            upper bound, negative below its lower bound; ``J q̇ - target`` on an
            equality row). The level minimised ``||v||`` given the levels above it.
        active_lower: indices of the inequality rows (``lower < upper``) at or below
            their lower bound (within the solver's ``tolerance``).
        active_upper: the same for the upper bound.
    """

    name: str
    slack: np.ndarray
    active_lower: tuple[int, ...]
    active_upper: tuple[int, ...]

    @property
    def violation(self) -> float:
        """``||slack||`` (2-norm): 0 when every row of the level holds."""
        return float(np.linalg.norm(self.slack))


@dataclass(frozen=True)
class HqpResult:
    """Outcome of :func:`solve_hqp` for a stack of L levels on n joints.

    Attributes:
        qdot: (n,) joint velocity realising the stack.
        free_dims: per level, the dimension of the space the rows fixed so far (the
            equality rows and the violated inequality rows of this level and those
            above) leave to the levels below; inequality rows that hold do not count.
        iterations: active-set iterations over all levels (one equality-constrained
            least-squares solve each).
        unsettled: the names of the levels whose active set stopped at its last-resort
            guard instead of reaching the level's optimum (the regularisation level is
            called ``"regularisation I q̇ = 0"``); empty when every level reached it, as on
            every problem the tests generate. q̇ then still keeps every inequality row of the
            levels above the first unsettled level that held at their optimum, and those
            levels' slacks: the robot is held back, not thrown.
        levels: one :class:`LevelReport` per level, highest priority first, computed
            when first read (a controller that does not read them does not pay).
    """

    qdot: np.ndarray
    free_dims: tuple[int, ...]
    iterations: int
    unsettled: tuple[str, ...] = ()
    names: tuple[str, ...] = field(default=(), repr=False)
    problem: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default=(), repr=False)
    tolerance: float = field(default=TOLERANCE, repr=False)

    @cached_property
    def levels(self) -> tuple[LevelReport, ...]:
        """Per level, its slack and active rows at the final q̇."""
        return tuple(
            level_report(name, *level, self.qdot, self.tolerance)
            for level, name in zip(self.problem, self.names, strict=True)
        )

    def level(self, name: str) -> LevelReport:
        """The report of the level called ``name``; KeyError listing the names otherwise."""
        for report in self.levels:
            if report.name == name:
                return report
        raise KeyError(f"no level named {name!r}; levels: {', '.join(self.names)}")


def level_report(
    name: str,
    J: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    qdot: np.ndarray,
    tolerance: float = TOLERANCE,
) -> LevelReport:
    """The :class:`LevelReport` of the level ``lower <= J q̇ <= upper`` (``lower is upper``, or equal,
    for equalities) at ``qdot``: its slack, and its inequality rows within ``tolerance`` of a bound."""
    value = J @ qdot
    at_lower, at_upper = _at_bounds(lower, upper, value, tolerance)
    return LevelReport(
        name=name,
        slack=value - np.clip(value, lower, upper),
        active_lower=tuple(np.flatnonzero(at_lower).tolist()),
        active_upper=tuple(np.flatnonzero(at_upper).tolist()),
    )


def _at_bounds(
    lower: np.ndarray, upper: np.ndarray, value: np.ndarray, tolerance: float
) -> tuple[np.ndarray, np.ndarray]:
    """The inequality rows (``lower < upper``) whose ``value`` is within ``tolerance`` of (or past)
    their lower bound, and those at their upper bound: two boolean masks."""
    inequality = lower < upper
    return inequality & (value <= lower + tolerance), inequality & (value >= upper - tolerance)


def bound_sides(
    J: np.ndarray, lower: np.ndarray, upper: np.ndarray, qdot: np.ndarray, tolerance: float = TOLERANCE
) -> np.ndarray:
    """The sides of the rows of ``lower <= J q̇ <= upper`` at ``qdot``, as :func:`solve_hqp`'s
    ``warm_start`` takes them: (m,) int8, +1 for a row at its upper bound (within ``tolerance``;
    :func:`level_report`'s ``active_upper``), -1 at its lower one only, 0 otherwise."""
    at_lower, at_upper = _at_bounds(lower, upper, J @ qdot, tolerance)
    return np.where(at_upper, 1, np.where(at_lower, -1, 0)).astype(np.int8)


def _level_names(names: Sequence[str] | None, count: int) -> tuple[str, ...]:
    """The names of ``count`` levels: ``names`` checked (non-empty strings, one per level, no two
    alike), or the levels' indices; ValueError naming what is wrong."""
    if names is None:
        return tuple(str(i) for i in range(count))
    names = tuple(validation.nonempty_string(f"names[{i}]", name) for i, name in enumerate(names))
    if len(names) != count:
        raise ValueError(f"names has {len(names)} entries but there are {count} levels")
    if len(set(names)) != len(names):
        twice = sorted({name for name in names if names.count(name) > 1})
        raise ValueError(f"names {twice} name two levels each: a level's name is its own")
    return names


def _levels_that_hold(levels: Sequence[HqpLevel]) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]] | None:
    """:func:`_validate_hqp`'s triples when every level is a pair or a triple of float64 arrays and
    one compiled check finds them valid (the same checks, without a few numpy calls per level: a
    tenth to a fifth of a solve of the tests' random hierarchies); None otherwise, for
    :func:`_validate_hqp`, which converts what it can and names what fails."""
    if kernels.compiled is None:
        return None
    for level in levels:
        if type(level) not in (tuple, list) or len(level) not in (2, 3):
            return None
        for a in level:
            if type(a) is not np.ndarray or a.dtype != np.float64:
                return None
    if not kernels.compiled.levels_hold(
        [level[0] for level in levels], [level[1] for level in levels], [level[-1] for level in levels]
    ):
        return None
    return [(level[0], level[1], level[-1]) for level in levels]


def _validate_hqp(
    levels: Sequence[HqpLevel], names: Sequence[str] | None
) -> tuple[list[tuple[np.ndarray, np.ndarray, np.ndarray]], tuple[str, ...]]:
    """``levels`` as ``(J, lower, upper)`` float triples and the level names, or ValueError
    naming the level (index and name) and, for bounds, the row."""
    names = _level_names(names, len(levels))
    checked: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
    for i, level in enumerate(levels):
        where = f"levels[{i}] ({names[i]!r})"
        if not isinstance(level, tuple | list) or len(level) not in (2, 3):
            got = f"{len(level)} entries" if isinstance(level, tuple | list) else type(level).__name__
            raise ValueError(f"{where} must be (J, target) or (J, lower, upper), got {got}")
        J = validation.matrix(f"{where}: J", level[0])
        if checked and J.shape[1] != checked[0][0].shape[1]:
            raise ValueError(
                f"{where}: J has shape {J.shape} but levels[0] J has shape {checked[0][0].shape}; "
                "all levels need the same number of columns"
            )
        if len(level) == 2:
            target = validation.vector(f"{where}: target", level[1], J.shape[0])
            checked.append((J, target, target))
        else:
            checked.append((J, *validation.bounds(where, level[1], level[2], J.shape[0])))
    return checked, names


def solve_hqp(
    levels: Sequence[HqpLevel],
    *,
    names: Sequence[str] | None = None,
    rank_threshold: float = 1e-6,
    tolerance: float = TOLERANCE,
    validate: bool = True,
    warm_start: HqpResult | Mapping[str, np.ndarray] | None = None,
    damping: float | Mapping[str, float] = 0.0,
) -> HqpResult:
    """Solve a strict hierarchy of equalities and inequalities (Escande, Mansard, Wieber 2014).

    Level k holds rows ``l_k <= J_k q̇ <= u_k`` (``l = u`` for an equality). The levels
    are solved lexicographically: level k minimises its slack,

        min ||v_k||²  over q̇ and v_k,  s.t.  l_k <= J_k q̇ - v_k <= u_k,

    while every level above keeps the slack it reached (its violated and equality
    rows keep their values, its inequality rows that hold keep holding), and a last
    level ``I q̇ = 0`` picks the minimum-norm q̇ among the solutions of all of them.

    Each level is an inequality-constrained least squares solved by a primal active
    set in the null-space basis form of :func:`~drake_sot.hierarchy.solve_strict`: ``q̇ = q̇_{k-1} + Z u``
    with ``Z`` an orthonormal basis of what the fixed rows above leave free. The level's
    own inequality rows are *soft*: a row outside its bounds, or that a step would take
    outside, joins the least squares at that bound (its residual is its slack, and its
    multiplier: it leaves when the residual turns to the inside). The rows of the levels
    above that hold are *hard*: a blocking one becomes an equality constraint (one more
    SVD, of ``C_act Z``, gives the directions left), and leaves when its Lagrange
    multiplier has the wrong sign. When the level is optimal, its equality rows and its
    violated rows are fixed (``Z`` shrinks by one SVD, as in :func:`~drake_sot.hierarchy.solve_strict`) and
    its rows that hold become hard rows for the levels below.

    Minimum norm: with equalities only no row is ever hard, every step is the
    minimum-norm least-squares step of :func:`~drake_sot.hierarchy.solve_strict` in the same basis (same
    ``rank_threshold``), so q̇ is its result (to rounding: the same decomposition per
    level) and lies in the row space of the augmented Jacobian, which is already the
    minimum norm. Consecutive levels of equalities given as ``(J, t, t)`` (the same array
    twice, as ``StackOfTasks`` passes them) take these same steps from one QR of their
    stacked Jacobian, as long as each level keeps its full row rank
    (:meth:`_ActiveSet.equality_run` says why the steps are the same). When hard rows
    exist, the steps of the active set may leave a component in the final free space;
    the regularisation level ``I q̇ = 0``, solved with the same active set, removes it
    (down to what the hard rows allow).

    Shortcut: when every inequality row holds at the solution of the equality levels alone,
    that solution is the answer and no active set runs (:func:`_inequalities_idle` says why
    and when it applies: a control tick whose limits do not bind). Without ``warm_start``, the
    rows that do not hold there are tried as the rows at a bound (the same function and its
    certificate: one more QR); with it, its rows are tried instead, first. A refused guess gives
    the next (:func:`_guessed`: the rows found outside added, those pulled inward dropped), up to
    :data:`GUESSES` equality solves before the active set.

    Where it runs: validation here, in Python, once; then the whole solve (shortcut, runs of
    equality levels, active set, damped levels included, regularisation) in one call to the
    compiled kernels when they are loaded, else in numpy (:func:`_solve_numpy`; the same
    decisions, q̇ the same to rounding). The compiled solve uses no BLAS: its time does not
    depend on the BLAS thread count.

    Why not DAQP's hierarchical mode: it is faster, but it makes each level soft with a fixed
    penalty (``rho_soft = 1e-8``, hard-coded in its ``daqp_hiqp``), so its q̇ can be
    lexicographically worse than the strict hierarchy's (measurements: ``benchmarks/README.md``).
    The equality-only case must equal
    :func:`~drake_sot.hierarchy.solve_strict` to 1e-9.

    Args:
        levels: ``(J_k, target_k)`` or ``(J_k, lower_k, upper_k)``, highest priority
            first; ``J_k`` is (m_k, n), the vectors (m_k,). Bounds may be ``±inf`` on
            their own side; rows of ``J_k`` that are exactly zero, or whose two bounds
            are infinite, constrain nothing and are skipped (their slack is reported).
        names: one name per level, used in the reports and error messages.
        rank_threshold: singular values at or below it are zero (as in
            :func:`~drake_sot.hierarchy.solve_strict`), finite >= 0.
        tolerance: a row within it of a bound is at that bound; a residual or
            multiplier on the wrong side by less is zero (absolute, in the rows' units),
            finite > 0.
        validate: check shapes, finiteness and bounds, and ``rank_threshold`` and
            ``tolerance`` (below). A caller that has checked them (``StackOfTasks`` checks
            the two numbers at construction and the signals at each tick, naming the
            task) may skip it.
        warm_start: the result of a previous call (e.g. the last control tick) whose active
            rows (:attr:`LevelReport.active_lower` / ``active_upper``, levels matched by name,
            rows by index) are the first guess of the rows at a bound. When the guess is still
            right and the problem has the shortcut's form (below), the answer is one equality
            solve with those rows at their bounds, certified by the signs of their multipliers
            (:func:`_inequalities_idle`); otherwise the next guesses are tried, then the active
            set runs, as without it. Only a guess: the result is the same either way (to
            rounding). Or, for a caller that keeps only the sides (a control system holding them in
            its state), a mapping from a level's name to its rows' sides at a bound
            (:func:`bound_sides`: +1 upper, -1 lower, 0 free).
        damping: μ of the damped least squares of every level, or a mapping from a level's name
            to its μ (the levels it does not name are exact); finite >= 0, in the units of the
            level's Jacobian; 0, the default, is the exact hierarchy above. With μ > 0 a level
            minimises ``||v_k||² + μ² ||q̇ - q̇_{k-1}||²`` over what the levels above leave
            (the damped least squares of Nakamura and Hanafusa 1986, per level as the SoT's
            damped inverse, :func:`~drake_sot.hierarchy.solve_strict`'s ``damping``; Escande,
            Mansard, Wieber 2014 discuss this damping of the levels): its step along a
            singular value σ of ``J_k Z`` is ``σ / (σ² + μ²)`` times the target instead of
            ``1/σ``, at most ``1 / (2μ)``. The rows it then fixes are fixed at the values it
            reached, as with μ = 0; the regularisation ``I q̇ = 0`` is not damped. Why: at a
            singularity of the level *given the levels above* (a joint held at its limit by a
            level above leaves the level only joints that barely move its task: an arm's elbow
            at its bound leaves the hand's reach along the forearm to the wrist; in
            ``telecooperation``, with an elbow held, the CoM's height below the feet's and the
            hands' tasks is left to joints that barely move it, the wrists), the exact step
            along σ → 0 is as large as the velocity bounds allow and its sign flips from a tick
            to the next: q̇ chatters; damped, it goes to zero with σ.
            The discrete loop then settles when, roughly, ``T ℓ |ė| / μ² < 1`` (T the control
            period, |ė| the level's target speed, ℓ = dσ/dθ the rate at which σ grows with the
            joint's angle θ away from the extremum). The shortcut and the runs of equality
            levels are exact solves: with a damped level, the levels go through the active set
            and ``warm_start`` is not used.

    Returns:
        The joint velocity, the per-level reports (slack, active rows), the free
        dimensions, the iteration count and the levels whose active set did not settle
        (:attr:`HqpResult.unsettled`, normally empty).

    Raises:
        ValueError: a level that is not a pair or a triple, shapes that disagree, NaN
            or Inf in a Jacobian or a target, NaN in a bound or ``lower > upper`` (the
            message names the level, its name, and the row), names of the wrong
            number, or a bad ``rank_threshold`` / ``tolerance`` / ``damping``. Nothing else: an active
            set that does not settle (:meth:`_ActiveSet._minimise`: Bland's rule, then a
            last-resort guard) gives the iterate it reached, named in ``unsettled``, not
            an error; a controller that stops its robot on a crash would rather hold it.
    """
    if validate:
        rank_threshold = nonnegative("rank_threshold", rank_threshold)
        tolerance = validation.positive("tolerance", tolerance)
        checked = _levels_that_hold(levels)
        if checked is None:
            checked, level_names = _validate_hqp(levels, names)
        else:
            level_names = _level_names(names, len(levels))
        mus = _dampings(damping, level_names)
    else:
        checked = [(lv[0], lv[1], lv[1]) if len(lv) == 2 else tuple(lv) for lv in levels]
        level_names = tuple(names) if names is not None else tuple(str(i) for i in range(len(checked)))
        mus = _dampings(damping, level_names, validate=False)
    if not checked:
        return HqpResult(qdot=np.zeros(0), free_dims=(), iterations=0)
    binding = None if warm_start is None or any(mus) else _binding(warm_start, checked, level_names)
    solve = _solve_numpy if kernels.compiled is None else _solve_compiled
    qdot, free_dims, iterations, unsettled = solve(
        checked, level_names, mus, rank_threshold, tolerance, binding
    )
    return HqpResult(
        qdot=qdot,
        free_dims=free_dims,
        iterations=iterations,
        unsettled=unsettled,
        names=level_names,
        problem=checked,
        tolerance=tolerance,
    )


#: What both solvers give :func:`solve_hqp`: q̇ (n,), the free dimensions, the iterations and the
#: unsettled levels' names.
_Solution = tuple[np.ndarray, tuple[int, ...], int, tuple[str, ...]]


def _solve_compiled(
    levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    names: tuple[str, ...],
    mus: list[float],
    rank_threshold: float,
    tolerance: float,
    binding: dict[int, tuple[np.ndarray, np.ndarray]] | None,
) -> _Solution:
    """:func:`_solve_numpy` in C++ (``drake_sot/kernels/hqp.cpp``: the same steps, decisions and rank
    floors, its answers the same to rounding where the rank decisions coincide), damped levels
    included; one call, with the GIL released, whose time does not depend on a BLAS thread count."""
    qdot, free_dims, iterations, unsettled = kernels.compiled.solve_hqp(
        [level[0] for level in levels],
        [level[1] for level in levels],
        [level[2] for level in levels],
        [level[1] is level[2] for level in levels],
        names,
        mus,
        rank_threshold,
        tolerance,
        None
        if binding is None
        else {index: (rows.tolist(), sides.tolist()) for index, (rows, sides) in binding.items()},
        _ActiveSet.BLAND_AFTER,
        _ActiveSet.ITERATIONS_PER_ROW,
        GUESSES,
        ALL_AT_ONCE,
    )
    return qdot, tuple(free_dims), iterations, tuple(unsettled)


def _solve_numpy(
    levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    names: tuple[str, ...],
    mus: list[float],
    rank_threshold: float,
    tolerance: float,
    binding: dict[int, tuple[np.ndarray, np.ndarray]] | None,
) -> _Solution:
    """:func:`solve_hqp` on validated levels, in numpy: the shortcut (:func:`_guessed`, not with a
    damped level) from the warm start's ``binding`` (:func:`_binding`), else the active set level
    by level, runs of equality levels together. The oracle of :func:`_solve_compiled`, and the
    package's path when the compiled kernels are not there (:mod:`drake_sot.kernels`)."""
    fast = None if any(mus) else _guessed(levels, rank_threshold, tolerance, binding)
    if fast is not None:
        qdot, free_dims = fast
        return qdot, free_dims, len(levels), ()
    solver = _ActiveSet(levels[0][0].shape[1], rank_threshold, tolerance)
    free_dims: list[int] = []
    i = 0
    while i < len(levels):
        run = i
        # exact equality levels (J, t, t)
        while run < len(levels) and levels[run][1] is levels[run][2] and not mus[run]:
            run += 1
        if run - i >= 2:
            i += solver.equality_run(levels[i:run], free_dims)
            if i == run:
                continue
        J, lower, upper = levels[i]
        solver.level(J, lower, upper, names[i], mus[i])
        free_dims.append(solver.free_dims)
        i += 1
    solver.regularise()
    return solver.x, tuple(free_dims), solver.iterations, tuple(solver.unsettled)


def _dampings(
    damping: float | Mapping[str, float], names: tuple[str, ...], validate: bool = True
) -> list[float]:
    """Per level, its μ: ``damping`` for every level, or, from a mapping, the μ of the levels it
    names (0 for the others). ``validate``: ValueError for a μ that is not finite >= 0 (naming its
    level) or a name that is no level's (listing the levels)."""
    if not isinstance(damping, Mapping):
        return [nonnegative("damping", damping) if validate else damping] * len(names)
    if validate:
        unknown = sorted(set(damping) - set(names))
        if unknown:
            raise ValueError(f"damping names {unknown}, not levels; levels: {', '.join(names)}")
        return [nonnegative(f"damping[{name!r}]", damping.get(name, 0.0)) for name in names]
    return [damping.get(name, 0.0) for name in names]


def _binding(
    previous: HqpResult | Mapping[str, np.ndarray],
    levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    names: tuple[str, ...],
) -> dict[int, tuple[np.ndarray, np.ndarray]] | None:
    """The rows of ``previous`` at a bound, as :func:`_inequalities_idle`'s ``binding``: per index of
    an inequality level of ``levels`` whose name ``previous`` knows, ``(rows, sides)`` (side +1 at
    the upper bound, -1 at the lower one; rows that this level does not have are left out).
    None when no row was at a bound."""
    if isinstance(previous, HqpResult):  # its inequality levels only (one J q̇ each)
        known = {
            name: bound_sides(J, lower, upper, previous.qdot, previous.tolerance)
            for name, (J, lower, upper) in zip(previous.names, previous.problem, strict=True)
            if lower is not upper and not (lower == upper).all()
        }
    else:
        known = previous
    binding: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for index, (name, (J, lower, upper)) in enumerate(zip(names, levels, strict=True)):
        side = known.get(name)
        if side is None or lower is upper:
            continue
        side = side[: J.shape[0]]
        rows = np.flatnonzero(side)
        if rows.size:
            binding[index] = (rows, side[rows].astype(float))
    return binding or None


#: A refused guess of :func:`_inequalities_idle`: per level the guessed rows whose multipliers
#: have the right sign, ``(rows, sides)``; the rows found outside, ``(-excess, level, row, side)``;
#: and how many rows a guess may hold (the equality rows above a tall last level must leave it a
#: dimension).
_Refusal = tuple[dict[int, tuple[np.ndarray, np.ndarray]], list[tuple[float, int, int, float]], int]


def _next_guess(refusal: _Refusal, count: int) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """The guess after a refused one: per level, its kept rows and sides, and the ``count``
    farthest out of the rows found outside, as many of them as fit beside the kept ones."""
    kept, added, room = refusal
    guess = {index: (rows.tolist(), sides.tolist()) for index, (rows, sides) in kept.items()}
    space = min(count, room - sum(len(rows) for rows, _ in guess.values()))
    for _, index, row, side in sorted(added)[: max(space, 0)]:
        rows, sides = guess.setdefault(index, ([], []))
        rows.append(row)
        sides.append(side)
    out = {}
    for index, (rows, sides) in guess.items():
        order = np.argsort(rows)
        out[index] = (np.asarray(rows, dtype=np.intp)[order], np.asarray(sides, dtype=float)[order])
    return out


#: How many guesses of the rows at a bound :func:`_guessed` tries before the active set.
GUESSES = 16
#: How many of them add all the rows the refused guess's q̇ leaves (then one at a time).
ALL_AT_ONCE = 4


def _guessed(
    levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    rank_threshold: float,
    tolerance: float,
    binding: dict[int, tuple[np.ndarray, np.ndarray]] | None,
) -> tuple[np.ndarray, tuple[int, ...]] | None:
    """:func:`_inequalities_idle` from the guess ``binding`` (None: no row at a bound), then from
    the guesses each refusal gives, up to :data:`GUESSES` guesses; each try is one equality solve,
    certified or refused, so a wrong guess costs time, never the answer. After a refusal the guess
    is its kept rows and all the rows found outside (at a limit met for the first time, the rows
    that the unlimited q̇ would cross are often those that bind), :data:`ALL_AT_ONCE` times; when
    those are refused too (rows crossed by the unlimited q̇ that a few others' binding brings back
    inside), or when the first refusal's rows do not all fit beside the equality rows (a sign of
    that), the guesses go on from the first refusal, adding the farthest row out of each refused
    guess's q̇, one at a time (the active set's one row per iteration, at one equality solve each). None when
    no guess was certified or a guess came back (the guesses cycle), for the active set."""
    seen: set[tuple] = set()
    first: _Refusal | None = None
    all_at_once = ALL_AT_ONCE
    for _ in range(GUESSES):
        key = (
            ()
            if binding is None
            else tuple((i, r.tobytes(), s.tobytes()) for i, (r, s) in sorted(binding.items()))
        )
        if key in seen:
            return None
        seen.add(key)
        following: list[_Refusal] = []
        fast = _inequalities_idle(levels, rank_threshold, tolerance, binding, following)
        if fast is not None or not following:
            return fast
        if first is None:
            first = following[0]
            kept, added, room = first
            if len(added) + sum(rows.size for rows, _ in kept.values()) > room:
                all_at_once = 0  # too many rows outside to fit beside the equality rows: one at a time
        if len(seen) < all_at_once:
            binding = _next_guess(following[0], len(following[0][1]))
        elif len(seen) == max(all_at_once, 1):  # from the first refusal, one row at a time
            binding = _next_guess(first, 1)
        else:
            binding = _next_guess(following[0], 1)
        binding = binding or None
    return None


def _inequalities_idle(
    levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
    rank_threshold: float,
    tolerance: float = TOLERANCE,
    binding: dict[int, tuple[np.ndarray, np.ndarray]] | None = None,
    following: list[_Refusal] | None = None,
) -> tuple[np.ndarray, tuple[int, ...]] | None:
    """q̇ and the free dimensions of :func:`solve_hqp` when its inequalities change nothing, else None.

    The strict hierarchy of the equality levels alone (the inequality levels left out) gives
    q̇*. If every inequality row holds at q̇*, q̇* is the hierarchy's solution with them: each
    level's optimum over a set is also its optimum over any subset that contains q̇*, and the
    inequality levels' slack is zero there. Level by level, the set the active set would leave
    to the levels below is the equality hierarchy's set intersected with the rows that hold; q̇*
    lies in each, so it is optimal at each level, and of least norm in the last (it is of least
    norm in the larger set of the equality hierarchy). No active set runs, and no hard row is
    tested on each step.

    Computed here only in the common form of a control tick, certified as the level-by-level
    steps of :func:`~drake_sot.hierarchy.solve_strict` are (the same rank decisions, the same
    step to rounding):
    every level is ``(J, t, t)`` (or ``lower == upper`` throughout) or an inequality level with
    ``lower < upper`` on every row; the equality levels but the last hold at most n rows
    together and each keeps its full row rank in what the levels above leave; the last one
    either fits too or is tall and takes all the freedom left with full column rank
    (:func:`~drake_sot.linalg.full_rank_lstsq`). With ``Aᵀ = Q R`` (Householder) for the stacked
    equality rows A, ``A = L Qᵀ`` with ``L = Rᵀ`` lower triangular in blocks, the hierarchy's
    steps are ``q̇* = Q₁ L⁻¹ t`` (one forward substitution; :meth:`_ActiveSet.equality_run` says
    why) and the last level's least squares runs in ``Z = Q₂``. The ranks are certified at once:
    the diagonal blocks ``L_ii⁻¹`` are those of ``L⁻¹``, so ``σ_min(L_ii) >= 1 / ||R⁻¹||_F``,
    while every level's SVD floor is at most ``max(rank_threshold, n eps ||A||_F)``. Anything
    else (a rank in doubt, an inequality row that does not hold at q̇*, a level of mixed rows)
    returns None, for the active set.

    Warm start: ``binding`` maps the index of an inequality level to the rows guessed at a bound
    (``(rows, sides)``, side +1 upper, -1 lower; e.g. those of the previous tick). They join the
    equality rows at their bounds, in their level's place, and q̇* is that equality hierarchy's
    solution; each level's slack is as small as over the larger set where they are free (they hold
    at q̇*, at zero slack, and the equality levels below them are met exactly, having full row rank),
    except in the last level, the tall one or the least-norm one, whose optimality over the larger
    set is the sign of their multipliers: with ``g`` that level's gradient at q̇* (``J_Lᵀ (J_L q̇* -
    t_L)``, or q̇* itself for the least norm), ``g = Aᵀ ν`` over the stacked rows A above it
    (``ν = R⁻¹ Q₁ᵀ g``), and a row at its upper bound needs ``ν <= tolerance`` for the least norm
    (the level would gain by moving it down otherwise), at its lower bound ``ν >= -tolerance``; for a
    tall last level strictly (``ν < -tolerance``, ``ν > tolerance``): a row it does not hold on may
    move in that level's optimal set, where the least norm decides. Then q̇* satisfies the
    hierarchy's optimality conditions level by level and is its solution; a wrong guess returns
    None, for the active set. The binding rows hold, so they do not count in the free dimensions
    (those a tall last level leaves are counted by one more QR and SVD: the rank of its rows in what
    the equality rows above leave).

    ``following``: when given (a list) and the answer is None because rows outside their bounds or
    guessed rows with a wrong multiplier refuse q̇* (not for a rank in doubt or another form), it
    receives what :func:`_guessed` makes the next guess of (a :data:`_Refusal`): per inequality
    level, its guessed rows whose multiplier has the right sign, and the rows q̇* leaves, with the
    side each leaves by and how far.
    """
    n = levels[0][0].shape[1]
    equalities: list[tuple[np.ndarray, np.ndarray]] = []  # (J, target)
    # (level, J, lower, upper, the rows of the level they are: None for all)
    inequalities: list[tuple[int, np.ndarray, np.ndarray, np.ndarray, np.ndarray | None]] = []
    # (first row among the guessed rows, level, rows, sides); the guessed rows are stacked after the
    # equality levels above a tall last level (the order of full-rank rows that are all met changes
    # neither q̇* nor the certificate), so that those levels' rows span the first columns of Q
    guessed: list[tuple[int, int, np.ndarray, np.ndarray]] = []
    guessed_rows: list[tuple[np.ndarray, np.ndarray]] = []  # (J, bound)
    free_dims: list[int] = []  # certified below: each equality row takes one dimension
    total, fixed = 0, 0  # rows stacked (binding ones included), equality rows
    last_is_equality, last_index, last_rows = False, 0, 0
    for index, (J, lower, upper) in enumerate(levels):
        if lower is not upper and (lower < upper).all():
            bound = None if binding is None else binding.get(index)
            if bound is None:
                inequalities.append((index, J, lower, upper, None))
            else:
                rows, sides = bound
                at = np.where(sides > 0, upper[rows], lower[rows])
                if not np.isfinite(at).all():
                    return None
                guessed_rows.append((J[rows], at))
                guessed.append((total - fixed, index, rows, sides))
                total += rows.size
                rest = np.ones(J.shape[0], dtype=bool)
                rest[rows] = False
                inequalities.append((index, J[rest], lower[rest], upper[rest], np.flatnonzero(rest)))
                last_is_equality = False
        elif lower is upper or (lower == upper).all():
            if J.shape[0]:
                equalities.append((J, upper))
                total += J.shape[0]
                fixed += J.shape[0]
                last_is_equality, last_index, last_rows = True, index, J.shape[0]
        else:
            return None
        free_dims.append(max(n - fixed, 0))
    if total > n and not last_is_equality:
        return None  # a tall block of guessed rows: not this form
    last = equalities.pop() if total > n else None  # a tall last level
    head = fixed - (0 if last is None else last_rows)  # the equality rows stacked before the guessed
    guessed = [(head + start, index, block, sides) for start, index, block, sides in guessed]
    equalities += guessed_rows
    rows = total - (0 if last is None else last[0].shape[0])
    if rows >= n and last is not None:
        return None
    x, Z = np.zeros(n), None
    if equalities:
        A = np.concatenate([J for J, _ in equalities]) if len(equalities) > 1 else equalities[0][0]
        qr, tau, _, info = _GEQRF(A.T)
        if info:
            return None
        R_inv, info = _TRTRI(qr[:rows])  # reads and writes the upper triangle of R only
        if info:
            return None
        R_inv *= _upper_mask(rows)
        r, a = R_inv.ravel(), A.ravel()
        floor = max(rank_threshold, n * _EPS * math.sqrt(float(a.dot(a))))  # ||R||_F = ||A||_F
        if math.sqrt(float(r.dot(r))) * floor >= 1.0:
            return None
        target = np.concatenate([t for _, t in equalities]) if len(equalities) > 1 else equalities[0][1]
        y = R_inv.T.dot(target)  # Rᵀ y = t, with R⁻¹ at hand (as equality_run's loop)
        if last is None:
            Q, _, info = _ORGQR(qr, tau)  # Q₁ (n, rows)
        else:
            padded = np.zeros((n, n), order="F")
            padded[:, :rows] = qr
            Q, _, info = _ORGQR(padded, tau)  # Q = [Q₁ Q₂] (n, n)
        if info:
            return None
        x = Q[:, :rows].dot(y)
        Z = Q[:, rows:]
    if last is not None:
        J, target = last
        u = full_rank_lstsq(J if Z is None else J.dot(Z), target - J.dot(x), rank_threshold)
        if u is None:
            return None
        x = x + (u if Z is None else Z.dot(u))
    added: list[tuple[float, int, int, float]] = []  # (-excess, level, row, side) of the rows q̇* leaves
    for index, J, lower, upper, of_level in inequalities:
        value = J.dot(x)
        above, below = value > upper, value < lower
        if above.any() or below.any():
            if following is None:
                return None
            for k in np.flatnonzero(above | below).tolist():
                excess = float(value[k] - upper[k] if above[k] else lower[k] - value[k])
                row = k if of_level is None else int(of_level[k])
                added.append((-excess, index, row, 1.0 if above[k] else -1.0))
    kept: dict[int, tuple[np.ndarray, np.ndarray]] = {}  # per level, the guessed rows that hold on
    dropped = False
    if guessed:
        if last is None:
            nu = R_inv.dot(y)  # q̇* = Q₁ y = Aᵀ ν with R ν = y
            wrong = tolerance  # the least norm is unique: a multiplier may be zero
        else:
            J, target = last
            nu = R_inv.dot(Q[:, :rows].T.dot(J.T.dot(J.dot(x) - target)))
            # A zero multiplier would leave its row free to move in the last level's optimal set,
            # where the least norm decides: only rows that the last level strictly holds on.
            wrong = -tolerance
        for start, index, block, sides in guessed:
            right = sides * nu[start : start + sides.size] < wrong
            if not right.all():
                if following is None:
                    return None
                dropped = True
            if right.any():
                kept[index] = (block[right], sides[right])
    if added or dropped:
        following.append((kept, added, n - 1 - (fixed - last_rows)))
        return None
    if guessed:
        if last is not None:
            # The last level fixes its rows in what the equality rows above it leave (the guessed
            # rows hold, they fix nothing): that space is wider than Z, its rank there is counted.
            # Those rows come first in the stack: the first columns of Q span them, the rest of Q
            # is a basis of what they leave.
            J = last[0].dot(Q[:, head:])
            left = J.shape[1] - SvdSplit.of(J, rank_threshold).rank
            free_dims[last_index:] = [left] * (len(free_dims) - last_index)
    return x, tuple(free_dims)


class _ActiveSet:
    """The state of :func:`solve_hqp` between levels: q̇ so far, the basis ``Z`` of what
    the fixed rows leave free (None for the identity), and the hard rows ``lo <= C q̇ <= hi``."""

    #: Active-set iterations allowed per level, per row and hard row it holds: a last-resort
    #: guard (:meth:`_minimise`), far above what the random problems of the tests take.
    ITERATIONS_PER_ROW = 50
    #: Iterations in a row without moving q̇ after which a level turns to Bland's rule.
    BLAND_AFTER = 5

    def __init__(self, n: int, rank_threshold: float, tolerance: float) -> None:
        self.n = n
        self.rank_threshold = rank_threshold
        self.tol = tolerance
        self.x = np.zeros(n)
        self.Z: np.ndarray | None = None
        self.C = np.zeros((0, n))
        self.lo = np.zeros(0)
        self.hi = np.zeros(0)
        self.c_norms = np.zeros(0)
        #: A lower bound of every hard row's distance to its nearer bound at q̇, and the largest
        #: 2-norm and 1-norm of a hard row: a step d with min(||d||₂ c_norm_max, ||d||∞ c_l1_max)
        #: < room cannot take a row out (|C_i d| <= ||C_i||₂ ||d||₂ and <= ||C_i||₁ ||d||∞), so it
        #: needs no ratio test.
        self.room = math.inf
        self.c_norm_max = 0.0
        self.c_l1_max: float | None = 0.0  # None: not computed since rows were added
        self.iterations = 0
        #: The names of the levels whose active set stopped at the guard (:meth:`_minimise`).
        self.unsettled: list[str] = []
        #: True while q̇ is still the zero vector (no step taken): J q̇ = 0 without a product.
        self.x_zero = True
        #: True while every level took one minimum-norm step: q̇ is then orthogonal to Z.
        self.min_norm = True

    @property
    def free_dims(self) -> int:
        return self.n if self.Z is None else self.Z.shape[1]

    def level(
        self, J: np.ndarray, lower: np.ndarray, upper: np.ndarray, name: str, damping: float = 0.0
    ) -> None:
        """Solve one level (damped by ``damping`` μ when > 0: :meth:`_finish`), then fix its
        equality and violated rows and keep the others as hard rows."""
        if self.Z is not None and not self.Z.shape[1]:
            return  # nothing left to move: the level cannot act, nor its rows change
        if lower is upper:
            # An equality level given as (J, target, target) (StackOfTasks' form): no bound to compare.
            # Its zero rows are kept: a zero row of J Z changes neither the SVD's kept part nor the step.
            first = None if damping else self._equality_step(J, upper)
            if first is not None or damping:
                equality = np.ones(J.shape[0], dtype=bool)
                side = np.full(J.shape[0], 2, dtype=np.int8)
                self._finish(J, lower, upper, equality, side, _NO_ROWS, name, first, damping)
            return
        equality = lower == upper
        if not equality.any():
            x_zero = self.x_zero
            value = None if x_zero else J @ self.x
            if (
                (lower <= self.tol).all() and (upper >= -self.tol).all()
                if x_zero
                else ((value <= upper + self.tol) & (value >= lower - self.tol)).all()
            ):
                # Inequalities that all hold: the level is met where it stands, its rows turn hard
                # (a zero row or one without bounds among them holds whatever q̇ does).
                self.iterations += 1
                self._add_hard(J, lower, upper)
                return
        keep = J.any(axis=1)
        if not equality.all():
            keep &= (lower > -_INF) | (upper < _INF)
        if not keep.all():
            J, lower, upper, equality = J[keep], lower[keep], upper[keep], equality[keep]
            if not J.shape[0]:
                return
        first = None
        if equality.all() and not damping:
            first = self._equality_step(J, upper)
            if first is None:
                return
        soft = np.flatnonzero(~equality)
        side = np.full(J.shape[0], 2, dtype=np.int8)  # 2: equality; ±1: held at upper/lower; 0: free
        if soft.size:
            # The inequality rows (all of them, without copies, in a level of inequalities only).
            Js, ls, us = (J, lower, upper) if soft.size == J.shape[0] else (J[soft], lower[soft], upper[soft])
            value = Js @ self.x
            side[soft] = np.where(value > us + self.tol, 1, np.where(value < ls - self.tol, -1, 0))
        self._finish(J, lower, upper, equality, side, soft, name, first, damping)

    def _finish(
        self,
        J: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        equality: np.ndarray,
        side: np.ndarray,
        soft: np.ndarray,
        name: str,
        first: tuple[SvdSplit, np.ndarray] | None,
        damping: float = 0.0,
    ) -> None:
        """The active set of a level that needs one (:meth:`_minimise`), then its rows fixed or made hard.

        With ``damping`` μ > 0 the level's least squares is damped (Tikhonov): the rows
        ``μ Zᵀ (q̇ - q̇_start)`` = 0 (``q̇_start`` the q̇ the level starts from) join it as
        equality rows for its active set only, so its step is, in each working set,
        ``(AᵀA + μ² I)⁻¹ Aᵀ b``: ``σ / (σ² + μ²)`` per singular value σ instead of ``1/σ``; they
        are neither fixed nor hard for the levels below."""
        if damping:
            self.min_norm = False
            m = J.shape[0]
            D = damping * (np.eye(self.n) if self.Z is None else self.Z.T)
            start = D @ self.x
            side_damped = np.concatenate((side, np.full(D.shape[0], 2, dtype=np.int8)))
            _, iterations = self._minimise(
                np.vstack((J, D)),
                np.concatenate((lower, start)),
                np.concatenate((upper, start)),
                side_damped,
                soft,
                name,
            )
            side[:] = side_damped[:m]
            last = None
        else:
            last, iterations = self._minimise(J, lower, upper, side, soft, name, first)
        # The level's optimum: its equality rows and violated rows keep their values below.
        if soft.size:
            Js, ls, us = (J, lower, upper) if soft.size == J.shape[0] else (J[soft], lower[soft], upper[soft])
            held = side[soft]
            residual = Js @ self.x - np.where(held == -1, ls, us)
            violated = (held != 0) & (np.abs(residual) > self.tol)
            fixed = equality.copy()
            fixed[soft[violated]] = True
            hard = soft[~violated]
        else:
            fixed, hard = None, soft
        n_fixed = J.shape[0] if fixed is None else int(fixed.sum())
        # One step whose least squares held exactly the rows now fixed: a minimum-norm step of
        # an equality level. Anything else (a row held at a bound that holds, a blocked step, a
        # row released) may leave a component in the free space, for the regularisation to remove.
        single = last is None or n_fixed == last[0]
        if iterations > 1 or not single:
            self.min_norm = False
        if n_fixed:
            if last is not None and single:
                N = last[1].null_basis()  # the least squares was on exactly these rows: reuse its SVD
            else:
                F = J if fixed is None else J[fixed]
                N = SvdSplit.of(F if self.Z is None else F @ self.Z, self.rank_threshold).null_basis()
            self.Z = N if self.Z is None else self.Z @ N
        if hard.size:
            self._add_hard(J[hard], lower[hard], upper[hard])

    def _equality_step(self, J: np.ndarray, target: np.ndarray) -> tuple[SvdSplit, np.ndarray] | None:
        """A level of equalities whose minimum-norm step of
        :func:`~drake_sot.hierarchy.solve_strict` keeps every hard row within its bounds (the
        common case): take that step and fix the level's rows, as :meth:`_minimise` would in
        its first iteration, without its active-set bookkeeping; return None. When a hard row
        blocks the step, change nothing and return the SVD and the step, :meth:`_minimise`'s
        first iteration."""
        Z, x = self.Z, self.x
        A = J if Z is None else J @ Z
        b = target if self.x_zero else target - J @ x
        m, k = A.shape
        # A tall level that takes all the freedom left: its least squares by QR.
        y = full_rank_lstsq(A, b, self.rank_threshold) if m >= k else None
        if y is None:
            split = SvdSplit.of(A, self.rank_threshold)
            r = split.rank
            # With V = Z Vᵀ_split: the step is V[:, :r] s⁻¹ Uᵀ b and the new basis V[:, r:] (one product).
            V = split.Vt.T if Z is None else Z @ split.Vt.T
            d = V[:, :r] @ ((split.U[:, :r].T @ b) / split.s[:r])
            basis = V[:, r:]
        else:
            split, d = None, y if Z is None else Z @ y
            basis = np.zeros((self.n, 0))
        if not self._step(d):
            return split or SvdSplit.of(A, self.rank_threshold), d
        self.iterations += 1
        self.Z = basis
        return None

    def _step(self, d: np.ndarray) -> bool:
        """Take the step ``q̇ += d`` unless a hard row blocks it (then change nothing, return False).
        A step below rounding (||d|| <= 1e-15 (1 + ||q̇||)) is not taken (True)."""
        x = self.x
        d_norm = math.sqrt(float(d @ d))
        if not d_norm > 1e-15 * (1.0 + math.sqrt(float(x @ x))):
            return True
        reach = d_norm * self.c_norm_max
        if reach >= self.room:
            if self.c_l1_max is None:
                self.c_l1_max = float(np.abs(self.C).sum(axis=1).max(initial=0.0))
            reach = min(reach, float(np.abs(d).max()) * self.c_l1_max)
        if reach < self.room:  # no hard row (or none within reach): no ratio test
            self.room -= reach
            self.x = x + d
        else:
            _, step, _ = _first_block(self.C, self.lo, self.hi, x, d, 1e-10 * d_norm * self.c_norms)
            if step < 1.0:
                return False
            self.x = x + d
            self.room = self._room(self.C, self.lo, self.hi)
        self.x_zero = False
        return True

    def equality_run(
        self, levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]], free_dims: list[int]
    ) -> int:
        """Consecutive levels of equalities, solved together while each takes its full row rank
        in what the levels above leave; returns how many of ``levels`` it solved (appending their
        free dimensions to ``free_dims``), the caller going on level by level from there.

        With the stacked ``A = (J_1; ...; J_p) Z`` (M <= k rows) and ``Aᵀ = Q R`` (Householder QR,
        Q complete), ``A = L Qᵀ``, ``L = Rᵀ`` lower triangular in blocks: ``J_i Z Q_j = L_ij``,
        zero for j > i. So ``J_i Z_{i-1}``, with the basis ``Z_{i-1} = Z Q[:, M_<i:]`` of what
        the levels above i leave, is ``[L_ii 0]``: its singular values are those of ``L_ii`` and,
        when they are all above the rank floor, :meth:`_equality_step`'s step is
        ``Z Q_i L_ii⁻¹ c_i`` with ``c_i = t_i - J_i q̇_{i-1}`` (the same step: the pseudo-inverse
        of ``[L_ii 0]`` is ``[L_ii⁻¹; 0]``). The rank floor is certified as in
        :func:`~drake_sot.linalg.full_rank_lstsq` (``σ_min(L_ii) >= 1 / ||L_ii⁻¹||_F``,
        ``σ_max <= ||L_ii||_F``). One QR for the run instead of one SVD per level. A level that
        is not certified, or whose step a hard row blocks, is left to :meth:`level` with
        ``Z = Z Q[:, M_<i:]``, a basis of what the levels before it leave.
        """
        Z, rt = self.Z, self.rank_threshold
        k = self.n if Z is None else Z.shape[1]
        count, total = 0, 0
        for J, _, _ in levels:
            if total + J.shape[0] > k:
                break
            total += J.shape[0]
            count += 1
        if count < 2:
            return 0
        J_all = np.vstack([level[0] for level in levels[:count]])
        A = J_all if Z is None else J_all @ Z
        qr, tau, _, info = _GEQRF(A.T)
        if info:
            return 0
        padded = np.zeros((k, k), order="F")
        padded[:, :total] = qr
        Q, _, info = _ORGQR(padded, tau)
        if info:
            return 0
        V = Q if Z is None else Z @ Q  # the levels' row spaces in order, then what they leave
        target = np.concatenate([level[1] for level in levels[:count]])
        c = target if self.x_zero else target - J_all @ self.x
        if self._equality_run_at_once(levels[:count], qr, V, c, k, free_dims):
            return count
        start = 0
        for i in range(count):
            end = start + levels[i][0].shape[0]
            R_inv, info = _TRTRI(qr[start:end, start:end])  # R_ii in the upper triangle; L_ii = R_iiᵀ
            if info:
                self.Z = V[:, start:]
                return i
            mask = _upper_mask(end - start)
            R_inv *= mask
            R = (qr[start:end, start:end] * mask).ravel()
            floor = max(rt, max(end - start, k - start) * _EPS * math.sqrt(float(R @ R)))
            r = R_inv.ravel()
            y = R_inv.T @ c[start:end]
            if math.sqrt(float(r @ r)) * floor >= 1.0 or not self._step(V[:, start:end] @ y):
                self.Z = V[:, start:]
                return i
            if end < total:  # the later levels' targets seen from the new q̇: c_j -= L_ji y_i
                c[end:] -= y @ qr[start:end, end:total]
            self.iterations += 1
            free_dims.append(k - end)
            start = end
        self.Z = V[:, total:]
        return count

    def _equality_run_at_once(
        self,
        levels: Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]],
        qr: np.ndarray,
        V: np.ndarray,
        c: np.ndarray,
        k: int,
        free_dims: list[int],
    ) -> bool:
        """:meth:`equality_run`'s steps for all of ``levels`` at once when every level is
        certified and no hard row is within reach of their sum; return False (nothing
        changed) otherwise, for the level-by-level loop.

        The loop's ``y_i = L_ii⁻¹ c_i`` with ``c_j -= L_ji y_i`` for the later levels is the
        forward substitution of ``L y = c``, ``L = Rᵀ``: one triangular solve; and the
        diagonal blocks of ``R⁻¹`` are the ``R_ii⁻¹`` whose norms certify each level's rank.
        The steps ``V_i y_i`` have norms ``||y_i||`` (V has orthonormal columns); when the sum
        of their reaches stays below the hard rows' room, each of the loop's :meth:`_step`
        would have been taken without a ratio test; otherwise the hard rows are evaluated
        where each of the loop's steps would end, and when they all hold there, each of its
        ratio tests would have let the step through. Either way their sum is taken in one
        step (a step below rounding, which the loop skips, is taken: it changes nothing).
        """
        sizes = tuple(level[0].shape[0] for level in levels)
        if 0 in sizes:  # a level without rows: left to the loop
            return False
        total = c.size
        R = qr[:total, :total]
        R_inv, info = _TRTRI(R)
        if info:
            return False
        starts, diagonal = _diagonal_blocks(sizes)
        R_inv *= diagonal  # only the diagonal blocks R_ii⁻¹ are needed below, for their norms
        inv_norms = np.add.reduceat(np.einsum("ij,ij->i", R_inv, R_inv), starts)
        norms = np.add.reduceat(np.einsum("ij,ij->i", R, R * diagonal), starts)
        floors = np.maximum(self.rank_threshold, np.maximum(sizes, k - starts) * _EPS * np.sqrt(norms))
        if not (inv_norms * floors * floors < 1.0).all():
            return False
        y, info = _TRTRS(R, c, lower=0, trans=1)  # Rᵀ y = c (the upper triangle of R only)
        if info:
            return False
        reach = float(np.sqrt(np.add.reduceat(y * y, starts)).sum()) * self.c_norm_max
        if reach < self.room:
            self.room -= reach
            x = self.x + V[:, :total] @ y
        else:
            # The hard rows hold along the loop's path iff they hold at its corners (they are
            # convex): where each step would have ended, q̇ + d_1 + ... + d_i.
            corners = np.cumsum(np.add.reduceat(V[:, :total] * y, starts, axis=1), axis=1)
            corners += self.x[:, None]
            after = self.C @ corners
            if not ((after <= self.hi[:, None]) & (after >= self.lo[:, None])).all():
                return False
            x = corners[:, -1]
            self.room = float(np.minimum(after[:, -1] - self.lo, self.hi - after[:, -1]).min())
        self.x, self.x_zero = x, self.x_zero and not y.any()
        self.iterations += len(levels)
        free_dims.extend((k - starts - sizes).tolist())
        self.Z = V[:, total:]
        return True

    def _add_hard(self, rows: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
        """Rows that hold at this level's optimum: the levels below must keep them holding."""
        norms = _row_norms(rows)
        self.room = min(self.room, self._room(rows, lower, upper))
        self.c_norm_max = max(self.c_norm_max, float(norms.max(initial=0.0)))
        self.c_l1_max = None
        if not self.C.shape[0]:
            self.C, self.lo, self.hi, self.c_norms = rows, lower, upper, norms
            return
        self.C = np.vstack((self.C, rows))
        self.lo = np.concatenate((self.lo, lower))
        self.hi = np.concatenate((self.hi, upper))
        self.c_norms = np.concatenate((self.c_norms, norms))

    def _room(self, rows: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> float:
        """The smallest distance of ``rows q̇`` to the nearer of its bounds (negative outside; inf
        when there are no rows or no finite bounds)."""
        if not rows.shape[0]:
            return math.inf
        if self.x_zero:
            return float(np.minimum(-lower, upper).min())
        value = rows @ self.x
        return float(np.minimum(value - lower, upper - value).min())

    def regularise(self) -> None:
        """The last level ``I q̇ = 0``: the minimum-norm q̇ among the solutions of all levels.

        When every level took one minimum-norm step, q̇ is already orthogonal to the free
        space and inside the hard rows: nothing to do.
        """
        if not self.min_norm and self.free_dims:
            zeros = np.zeros(self.n)
            equality = np.full(self.n, 2, dtype=np.int8)
            self._minimise(np.eye(self.n), zeros, zeros, equality, _NO_ROWS, "regularisation I q̇ = 0")

    def _minimise(
        self,
        A: np.ndarray,
        lower: np.ndarray,
        upper: np.ndarray,
        side: np.ndarray,
        soft: np.ndarray,
        name: str,
        first: tuple[SvdSplit, np.ndarray] | None = None,
    ) -> tuple[tuple[int, SvdSplit] | None, int]:
        """Primal active set on one level; updates ``self.x`` and ``side`` in place.

        ``side`` is 2 for an equality row, ±1 for an inequality row held at its
        upper/lower bound (in the least squares), 0 for a free one; ``soft`` lists the
        inequality rows. Returns the row count and the SVD of the last least squares when
        it ran with no hard row held (its null space is what the level leaves; None
        otherwise), and the number of iterations. ``first``: the SVD and the step of the first
        iteration when the caller has them (:meth:`_equality_step`, blocked), not recomputed.

        Anti-cycling: each iteration either moves q̇ (the level's cost decreases) or changes the
        working set where q̇ stands. On a degenerate point (rows at their bounds with zero
        multipliers, rows that depend on the held ones) the usual choices (the first row to
        block, the row whose multiplier is the most wrong) can cycle through working sets
        without moving. After :attr:`BLAND_AFTER` consecutive iterations that did not move q̇,
        the level switches to Bland's smallest-index rule for good: the blocking row is the
        first in a fixed order (the level's rows, then the hard rows) among those that block
        at the shortest step, and the row that leaves is the first in that order among those
        whose multiplier has the wrong sign. Last resort, far past what Bland's rule needs:
        after ``ITERATIONS_PER_ROW`` iterations per row the level stops where it stands (q̇
        keeps every hard row, the levels above keep their optimum) and its name is added to
        :attr:`unsettled`.
        """
        Z, C, tol, rt = self.Z, self.C, self.tol, self.rank_threshold
        hard = np.zeros(C.shape[0], dtype=np.int8)  # 0 free, ±1 held at upper/lower
        held = _NO_ROWS
        limit = self.ITERATIONS_PER_ROW * (A.shape[0] + C.shape[0] + 1)
        x = self.x
        still, bland = 0, False  # iterations in a row that did not move q̇; Bland's rule on
        last = None
        for iteration in range(1, limit + 1):
            self.iterations += 1
            if held.size:
                rows_held = C[held]
                constraint = SvdSplit.of(rows_held if Z is None else rows_held @ Z, rt)
                N = constraint.null_basis()
                ZN = N if Z is None else Z @ N
            else:
                ZN = Z
            if soft.size:
                rows = np.flatnonzero(side)
                AW = A[rows]
                target = np.where(side[rows] == -1, lower[rows], upper[rows])
            else:
                rows, AW, target = None, A, upper
            last = None
            moved = False
            if AW.shape[0] and (ZN is None or ZN.shape[1]):
                if first is None:
                    split = SvdSplit.of(AW if ZN is None else AW @ ZN, rt)
                    y = split.solve(target - AW @ x)
                    d = y if ZN is None else ZN @ y
                else:  # the first iteration, already computed (the same least squares)
                    (split, d), first = first, None
                if not held.size:
                    last = (AW.shape[0], split)
                d_norm = math.sqrt(float(d @ d))
                if d_norm > 1e-15 * (1.0 + math.sqrt(float(x @ x))):
                    # Ratio test: the free soft rows and the free hard rows stay within their bounds.
                    alpha, blocker = 1.0, None
                    if soft.size:
                        free = soft[side[soft] == 0]
                        if free.size:
                            Af = A[free]
                            k, step, bound = _first_block(
                                Af, lower[free], upper[free], x, d, 1e-10 * d_norm * _row_norms(Af), bland
                            )
                            if step < alpha:
                                alpha, blocker = step, (side, int(free[k]), bound)
                    if C.shape[0]:
                        free = np.flatnonzero(hard == 0) if held.size else None
                        M, lo, hi, norms = (
                            (C, self.lo, self.hi, self.c_norms)
                            if free is None
                            else (C[free], self.lo[free], self.hi[free], self.c_norms[free])
                        )
                        k, step, bound = _first_block(M, lo, hi, x, d, 1e-10 * d_norm * norms, bland)
                        if step < alpha:
                            alpha, blocker = step, (hard, int(k if free is None else free[k]), bound)
                    moved = alpha * d_norm > 1e-15 * (1.0 + math.sqrt(float(x @ x)))
                    x = x + alpha * d
                    if blocker is not None:
                        status, row, bound = blocker
                        status[row] = bound
                        if status is hard:
                            held = np.flatnonzero(hard)
                        still = 0 if moved else still + 1
                        bland = bland or still >= self.BLAND_AFTER
                        continue
            # A full step (or none possible): the least squares is optimal on this active set.
            leaving = None
            if AW.shape[0] and (soft.size or held.size):
                candidates: list[tuple[float, np.ndarray, int]] = []  # (how wrong, status, row)
                residual = AW @ x - target
                if soft.size:
                    held_side = side[rows]
                    inequality = held_side != 2
                    if inequality.any():
                        wrong = -held_side[inequality] * residual[inequality]  # < 0: pulled outward, fine
                        candidates += _leaving(wrong, rows[inequality], side, tol, bland)
                if held.size and not (bland and candidates):
                    g = AW.T @ residual
                    if Z is not None:
                        g = Z.T @ g
                    r = constraint.rank
                    multiplier = constraint.U[:, :r] @ ((constraint.Vt[:r] @ -g) / constraint.s[:r])
                    candidates += _leaving(-hard[held] * multiplier, held, hard, tol, bland)
                if candidates:
                    leaving = candidates[0] if bland else max(candidates, key=lambda c: c[0])
            if leaving is None:
                self.x = x
                self.x_zero = False
                self.room = self._room(C, self.lo, self.hi)
                return last, iteration
            _, status, row = leaving
            if status is hard:
                hard[row] = 0
                held = np.flatnonzero(hard)
            else:  # free the row, unless it has crossed to its other bound
                value = float(A[row] @ x)
                side[row] = 1 if value > upper[row] + tol else (-1 if value < lower[row] - tol else 0)
            still = 0 if moved else still + 1
            bland = bland or still >= self.BLAND_AFTER
        # The guard: q̇ stays where the active set stands (it keeps every hard row).
        self.x = x
        self.x_zero = self.x_zero and not x.any()
        self.room = self._room(C, self.lo, self.hi)
        self.unsettled.append(name)
        return None, limit


def _leaving(
    wrong: np.ndarray, rows: np.ndarray, status: np.ndarray, tol: float, bland: bool
) -> list[tuple[float, np.ndarray, int]]:
    """The candidate to leave among held rows whose multiplier is wrong by ``wrong`` (> ``tol``:
    wrong sign): ``[(wrong, status, row)]`` for the most wrong, or under Bland's rule the one of
    smallest index (``rows`` increasing); ``[]`` when none is."""
    if bland:
        over = np.flatnonzero(wrong > tol)
        return [(float(wrong[over[0]]), status, int(rows[over[0]]))] if over.size else []
    k = int(np.argmax(wrong))
    return [(float(wrong[k]), status, int(rows[k]))] if wrong[k] > tol else []


_NO_ROWS = np.zeros(0, dtype=np.intp)


def _row_norms(M: np.ndarray) -> np.ndarray:
    """The 2-norm of each row of ``M``."""
    return np.sqrt(np.einsum("ij,ij->i", M, M))


def _first_block(
    M: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    x: np.ndarray,
    d: np.ndarray,
    eps: np.ndarray,
    lowest: bool = False,
) -> tuple[int, float, int]:
    """The first of the rows ``lower <= M q̇ <= upper`` that the step ``x + alpha d`` leaves:
    ``(row, alpha >= 0, +1 upper / -1 lower)``, or ``(-1, inf, 0)`` when none does. A row
    moves when ``|M_i d| > eps_i``; one already past its bound (rounding) blocks at once.
    ``lowest``: among the rows that block at the shortest step (to 1e-12), the one of smallest
    index (Bland's rule) instead of any."""
    after = M @ (x + d)
    if ((after <= upper) & (after >= lower)).all():
        return -1, _INF, 0  # the whole step stays inside every row (the common case)
    rate = M @ d
    value = M @ x
    up = rate > eps
    down = rate < -eps
    if not (up.any() or down.any()):
        return -1, _INF, 0
    steps = np.full(rate.shape, _INF)
    np.divide(upper - value, rate, out=steps, where=up)
    np.divide(lower - value, rate, out=steps, where=down)
    k = int(np.argmin(steps))
    step = max(float(steps[k]), 0.0)
    if lowest:
        k = int(np.flatnonzero(steps <= step + 1e-12)[0])
    return k, step, 1 if up[k] else -1
