"""The pure helpers refuse what would give a silent wrong result: each case that returned NaN, inf, a
misread flag or a misleading error, then a property test per helper (random arguments, numbers of
every kind): a finite result that obeys the helper's contract, or a ValueError; each example
bounded in time."""

from __future__ import annotations

import math
from datetime import timedelta

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot import validation
from drake_sot.admittance import MassDamperSpring
from drake_sot.channel import Link
from drake_sot.features import interaction_matrix, selection_indices
from drake_sot.hierarchy import solve_strict
from drake_sot.hqp import solve_hqp
from drake_sot.quasistatic import QsTask
from drake_sot.stabilization import divergent_component, low_pass, project_into_polygon
from drake_sot.transitions import smooth_step

#: The time an example of a property test may take (a few small numpy calls).
BOUND = settings(max_examples=100, deadline=timedelta(seconds=5))
SQUARE = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])  # counter-clockwise

#: Numbers of every kind a caller may pass: NaN, infinities, huge and tiny floats, huge integers.
numbers = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(10**400), max_value=10**400),
    st.sampled_from([0.0, -0.0, 1e-300, -1e-300, 1e300, 5e-324]),
)


# --- each case --------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("flags", "bad"),
    [(["0", "1", "1"], "'0'"), ([2, 0, 1], "2"), ([0.5, 1, 1], "0.5"), ([1, 1, None], "None")],
)
def test_a_selection_flag_that_is_no_boolean_is_refused(flags, bad):
    with pytest.raises(ValueError, match=f"flag {bad} is not a boolean"):
        selection_indices(flags, 3)


def test_booleans_and_zero_one_integers_select():
    assert selection_indices([True, False, True], 3).tolist() == [0, 2]
    assert selection_indices(np.array([1, 0, 1]), 3).tolist() == [0, 2]
    assert selection_indices(np.array([False, True]), 2).tolist() == [1]
    assert selection_indices("011", 3).tolist() == [1, 2]


def test_a_complex_jacobian_is_refused_by_every_solver_and_check():
    J = np.eye(2) + 1j * np.eye(2)
    with pytest.raises(ValueError, match="complex"):
        solve_strict([(J, np.ones(2))])
    with pytest.raises(ValueError, match="complex"):
        solve_hqp([(J, np.ones(2))])
    with pytest.raises(ValueError, match="complex"):
        validation.matrix("J", J)
    with pytest.raises(ValueError, match="must be a number"):
        validation.finite("x", 1 + 2j)


def test_solve_hqp_refuses_two_levels_of_one_name():
    J = np.eye(2)
    with pytest.raises(ValueError, match=r"names \['a'\] name two levels each"):
        solve_hqp([(J, np.ones(2)), (J, np.zeros(2))], names=["a", "a"])


def test_a_level_of_three_for_solve_strict_says_what_a_level_is():
    J = np.eye(2)
    with pytest.raises(ValueError, match=r"levels\[0\] must be a pair \(J, edot\), got 3 entries"):
        solve_strict([(J, np.zeros(2), np.ones(2))])
    with pytest.raises(ValueError, match=r"levels\[0\] \('0'\) must be .*got 4 entries"):
        solve_hqp([(J, np.zeros(2), np.ones(2), np.ones(2))])


def test_a_clockwise_polygon_is_the_same_polygon():
    """The nearest point of the unit square to (2, 0.5) is (1, 0.5); 0.1 inside it, (0.9, 0.5)."""
    for polygon in (SQUARE, SQUARE[::-1]):
        np.testing.assert_allclose(project_into_polygon(polygon, [2.0, 0.5]), [1.0, 0.5], atol=1e-12)
        np.testing.assert_allclose(project_into_polygon(polygon, [2.0, 0.5], 0.1), [0.9, 0.5], atol=1e-12)


def test_a_repeated_or_aligned_vertex_is_dropped_and_two_vertices_refused():
    """The triangle (0, 0), (1, 0), (0, 1): the nearest point to (2, 2) is (0.5, 0.5) (on the
    hypotenuse, by symmetry); with the repeated vertex, or a vertex on an edge, the same."""
    repeated = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 0.0], [0.0, 1.0]])
    aligned = np.array([[0.0, 0.0], [0.5, 0.0], [1.0, 0.0], [0.0, 1.0]])
    for polygon in (repeated, aligned):
        np.testing.assert_allclose(project_into_polygon(polygon, [2.0, 2.0]), [0.5, 0.5], atol=1e-12)
    with pytest.raises(ValueError, match="polygon has 2 vertices"):
        project_into_polygon(SQUARE[:2], [2.0, 2.0])
    with pytest.raises(ValueError, match="turns both ways"):
        project_into_polygon(np.array([[0.0, 0.0], [1.0, 0.0], [0.2, 0.2], [0.0, 1.0]]), [2.0, 2.0])


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: MassDamperSpring(1e-300, 1.0, 1e300, dt=0.005, n=1), "axis 0: mass = 1e-300"),
        (lambda: MassDamperSpring(1.0, 1.0, 1e300, dt=0.005, n=1), "axis 0: .*stiffness = 1e\\+300"),
        (lambda: low_pass(np.zeros(2), np.ones(2), 0.005, math.nan), "tau = nan"),
        (lambda: low_pass(np.zeros(2), np.ones(2), 0.005, -1.0), "tau = -1.0"),
        (lambda: low_pass(np.zeros(2), np.ones(2), math.nan, 0.1), "dt = nan"),
        (lambda: divergent_component(np.zeros(2), np.ones(2), 0.0), "omega = 0.0"),
        (lambda: divergent_component(np.zeros(2), np.ones(2), math.nan), "omega = nan"),
        (lambda: divergent_component(np.zeros(2), np.ones(2), 5e-324), "omega = 5e-324"),
        (lambda: interaction_matrix(math.nan, 0.0, 1.0), "x = nan"),
        (lambda: interaction_matrix(0.0, 1e200, 1.0), "y = 1e\\+200"),
        (lambda: QsTask("hand", np.eye(3), weight=math.nan), "QsTask 'hand' weight = nan"),
        (lambda: QsTask("hand", np.eye(3), weight=-1.0), "QsTask 'hand' weight = -1.0"),
        (lambda: QsTask("hand", np.eye(3), weight=0.0), "QsTask 'hand' weight = 0.0"),
        (lambda: Link.start(None, [0.0]).receive(math.nan), "now = nan"),
    ],
)
def test_what_gave_nan_or_was_held_silently_is_refused_by_name(call, message):
    with pytest.raises(ValueError, match=message):
        call()


def test_smooth_step_over_a_huge_span_is_the_raised_cosine():
    """Over [-1e308, 1.7e308], t = 1.5e308 is (1.5 + 1) / (1.7 + 1) of the way; the middle of
    [-1e308, 1e308] is 0: there the profile is 1/2."""
    u = (1.5 + 1.0) / (1.7 + 1.0)
    expected = 0.5 - 0.5 * math.cos(math.pi * u)
    assert smooth_step(1.5e308, -1e308, 1.7e308) == pytest.approx(expected, rel=1e-12)
    assert smooth_step(np.array([1.5e308]), -1e308, 1.7e308)[0] == pytest.approx(expected, rel=1e-12)
    assert smooth_step(0.0, -1e308, 1e308) == pytest.approx(0.5, rel=1e-12)


# --- a property test per helper ---------------------------------------------------------------

flags = st.one_of(
    st.booleans(), st.integers(-3, 3), st.floats(allow_nan=True), st.text(max_size=2), st.none()
)


@BOUND
@given(
    selection=st.one_of(st.none(), st.text(max_size=8), st.lists(flags, max_size=8)), size=st.integers(1, 6)
)
def test_selection_indices_selects_or_refuses(selection, size):
    try:
        rows = selection_indices(selection, size)
    except ValueError:
        return
    assert rows.size and np.all((0 <= rows) & (rows < size)) and np.all(np.diff(rows) > 0)
    if isinstance(selection, list):
        assert all(isinstance(f, bool) or (isinstance(f, int) and f in (0, 1)) for f in selection)


@BOUND
@given(
    names=st.lists(st.sampled_from(["a", "b", "c"]), min_size=1, max_size=3),
    entries=st.integers(1, 4),
    value=numbers,
    imaginary=st.booleans(),
)
def test_the_solvers_solve_or_refuse(names, entries, value, imaginary):
    J = np.eye(2) + (1j if imaginary else 0.0) * np.eye(2)
    level = (J, *[np.full(2, float(value) if abs(value) < 1e300 else math.inf)] * (entries - 1))
    for solve in (
        lambda: solve_strict([level] * len(names)),
        lambda: solve_hqp([level] * len(names), names=names),
    ):
        try:
            result = solve()
        except ValueError:
            continue
        assert np.all(np.isfinite(result.qdot))


coordinates = st.floats(min_value=-10.0, max_value=10.0, allow_nan=False)


@BOUND
@given(
    polygon=st.lists(st.tuples(coordinates, coordinates), min_size=0, max_size=7),
    point=st.tuples(coordinates, coordinates),
    margin=st.one_of(st.floats(0.0, 1.0), numbers),
)
def test_project_into_polygon_gives_a_point_inside_or_refuses(polygon, point, margin):
    """The point returned is inside each edge's half-plane moved inward by the margin (checked
    against the convex hull of the vertices, which the polygon must be when it is accepted)."""
    vertices = np.array(polygon, dtype=float).reshape(-1, 2)
    try:
        inside = project_into_polygon(vertices, point, margin)
    except ValueError:
        return
    assert np.all(np.isfinite(inside))
    from scipy.spatial import ConvexHull

    hull = ConvexHull(vertices)
    normals, offsets = hull.equations[:, :2], hull.equations[:, 2]  # n · x + o <= 0 inside
    assert np.all(normals @ inside + offsets <= -float(margin) + 1e-6)


@BOUND
@given(mass=numbers, damping=numbers, stiffness=numbers, dt=numbers)
def test_mass_damper_spring_steps_finitely_or_refuses(mass, damping, stiffness, dt):
    try:
        model = MassDamperSpring(mass, damping, stiffness, dt, n=1)
    except ValueError:
        return
    x, v = model.step(np.array([0.1]), np.array([0.0]), np.array([1.0]))
    assert np.all(np.isfinite(x)) and np.all(np.isfinite(v))


@BOUND
@given(
    dt=numbers,
    tau=numbers,
    omega=numbers,
    t=numbers,
    t1=numbers,
    t2=numbers,
    x=numbers,
    y=numbers,
    depth=numbers,
)
def test_the_filters_and_profiles_are_finite_or_refuse(dt, tau, omega, t, t1, t2, x, y, depth):
    checks = (
        (lambda: low_pass(np.zeros(2), np.ones(2), dt, tau), lambda r: np.all((0.0 <= r) & (r <= 1.0))),
        (lambda: divergent_component(np.zeros(2), np.ones(2), omega), lambda r: np.all(np.isfinite(r))),
        (lambda: smooth_step(t, t1, t2), lambda r: 0.0 <= r <= 1.0),
        (lambda: interaction_matrix(x, y, depth), lambda r: np.all(np.isfinite(r))),
    )
    for call, holds in checks:
        try:
            result = call()
        except ValueError:
            continue
        assert holds(result), result


@BOUND
@given(weight=numbers, now=numbers)
def test_qs_task_weights_and_link_times_are_numbers_or_refused(weight, now):
    try:
        task = QsTask("hand", np.eye(3), weight=weight)
    except ValueError:
        pass
    else:
        assert 0.0 < task.weight <= 1e8
    link = Link.start(None, [0.0]).carry(0.0, 0.5, [1.0])
    try:
        received = link.receive(now)
    except ValueError:
        assert isinstance(now, int) or not math.isfinite(now)
    else:
        assert received.value[0] == (1.0 if now >= 0.5 - 1e-9 else 0.0)
