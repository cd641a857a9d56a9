"""PatternGenerator: commands, limits, the frozen preview window, steering, references."""

import math

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator

from drake_sot.footsteps import WALKING_BOUNDS, Footstep, StepLimits, StepTiming
from drake_sot.systems.pattern_generator import PatternGenerator
from drake_sot.walk_planner import FOOTPRINTS_AHEAD

LEFT, RIGHT = Footstep(0.0, 0.095, 0.0, "left"), Footstep(0.0, -0.095, 0.0, "right")
TIMING = StepTiming(single_support=0.7, double_support=0.1, step_height=0.05)
HORIZON = 1.6


def _pg():
    pg = PatternGenerator(LEFT, RIGHT, com_height=0.81, timing=TIMING, horizon=HORIZON)
    simulator = Simulator(pg)
    simulator.Initialize()
    return pg, simulator, simulator.get_mutable_context()


def _out(pg, context, name):
    return pg.GetOutputPort(name).Eval(context)


def test_standing_outputs_hold_the_initial_stance():
    pg, sim, context = _pg()
    sim.AdvanceTo(1.0)
    np.testing.assert_allclose(_out(pg, context, "com")[:2], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(_out(pg, context, "com")[2], 0.81)
    np.testing.assert_allclose(_out(pg, context, "left_foot").translation(), [0.0, 0.095, 0.0], atol=1e-12)
    assert _out(pg, context, "phase")[0] == 0 and _out(pg, context, "in_process")[0] == 0
    np.testing.assert_allclose(_out(pg, context, "load"), [0.5, 0.5])


def test_steps_follow_the_plan_and_never_enter_the_preview_window():
    pg, sim, context = _pg()
    sim.AdvanceTo(0.5)
    steps = [Footstep(0.2, -0.095, 0.0, "right"), Footstep(0.4, 0.095, 0.0, "left")]
    pg.add_steps(context, steps)
    landings = pg.planned_landings(context)
    assert [s for _, s in landings] == steps
    first_landing = landings[0][0]
    # The first step (double support + single support, landing on its last sample) starts
    # no earlier than one horizon from now.
    step_start = first_landing + 0.005 - (TIMING.single_support + TIMING.double_support)
    assert step_start >= 0.5 + HORIZON - 1e-9
    assert _out(pg, context, "in_process")[0] == 1
    # Follow the walk. Mid-swing: the ZMP reference is on the stance sole, the swing foot
    # lifted; at each landing the swinging foot is on its footprint, on the ground.
    for t, step in landings:
        stance = "left" if step.side == "right" else "right"
        sim.AdvanceTo(t - TIMING.single_support / 2)
        assert _out(pg, context, "phase")[0] == (1 if stance == "left" else 2)
        stance_sole = _out(pg, context, f"{stance}_foot").translation()
        np.testing.assert_allclose(_out(pg, context, "zmp_ref"), stance_sole[:2], atol=1e-9)
        assert _out(pg, context, f"{step.side}_foot").translation()[2] == pytest.approx(
            TIMING.step_height, rel=1e-3
        )
        np.testing.assert_array_equal(_out(pg, context, "contacts"), [stance == "left", stance == "right"])
        sim.AdvanceTo(t + 1e-9)
        X = _out(pg, context, f"{step.side}_foot")
        np.testing.assert_allclose(X.translation(), [step.x, step.y, 0.0], atol=1e-9)
    sim.AdvanceTo(landings[-1][0] + 3.0)
    # Stopped: the CoM of the cart-table model settles over the middle of the last stance.
    np.testing.assert_allclose(_out(pg, context, "zmp_ref"), [0.3, 0.0], atol=1e-15)
    np.testing.assert_allclose(_out(pg, context, "com")[:2], [0.3, 0.0], atol=1e-4)
    assert _out(pg, context, "in_process")[0] == 0


def test_stepseq_is_relative_to_the_other_foot():
    pg, sim, context = _pg()
    pg.parsecmd(context, ":stepseq 0.2 -0.19 0.0  0.2 0.19 0.3")
    landings = [s for _, s in pg.planned_landings(context)]
    assert landings[0] == Footstep(0.2, -0.095, 0.0, "right")
    # Left foot: 0.2 ahead and 0.19 to the left of the right footprint, turned by 0.3 rad.
    assert (landings[1].x, landings[1].y, landings[1].yaw, landings[1].side) == pytest.approx(
        (0.4, 0.095, 0.3, "left")
    )


def test_parsecmd_timing_and_model_verbs():
    pg, sim, context = _pg()
    pg.parsecmd(context, ":singlesupporttime 0.78")
    pg.parsecmd(context, ":doublesupporttime 0.12")
    pg.parsecmd(context, ":stepheight 0.04")
    pg.parsecmd(context, ":comheight 0.8")
    pg.parsecmd(context, ":previewcontroltime 1.2")
    sim.AdvanceTo(0.1)
    assert _out(pg, context, "com")[2] == pytest.approx(0.8)
    pg.parsecmd(context, ":stepseq 0.1 -0.19 0")
    ((t_land, _),) = pg.planned_landings(context)
    # One horizon (1.2 s) of standing, then 0.12 s double support and 0.78 s single support.
    assert t_land == pytest.approx(0.1 + 1.2 + 0.12 + 0.78 - 0.005, abs=0.011)
    with pytest.raises(ValueError, match="only while standing"):
        pg.parsecmd(context, ":comheight 0.7")


def test_bad_commands_and_steps_are_refused_by_name():
    pg, sim, context = _pg()
    with pytest.raises(
        ValueError,
        match="unknown command ':walkfast'; known: :comheight, :doublesupporttime, :previewcontroltime, ",
    ):
        pg.parsecmd(context, ":walkfast 1")
    with pytest.raises(ValueError, match=":stepseq: takes x y yaw triples"):
        pg.parsecmd(context, ":stepseq 0.1 0.2")
    with pytest.raises(ValueError, match="must be numbers"):
        pg.parsecmd(context, ":stepheight high")
    before = pg.footprints(context)
    crossing = Footstep(0.1, 0.05, 0.0, "right")  # right foot to the left of the left foot
    with pytest.raises(ValueError, match="min_width"):
        pg.add_steps(context, [Footstep(0.1, -0.095, 0.0, "right"), crossing])
    with pytest.raises(ValueError, match="max_stride"):
        pg.add_steps(context, [Footstep(0.6, -0.095, 0.0, "right")])
    assert pg.footprints(context) == before  # nothing of a refused batch is planned
    with pytest.raises(ValueError, match="max_stride"):
        pg.set_velocity(context, 1.0, 0.0, 0.0)  # 0.8 m per step


def test_velocity_mode_keeps_four_footprints_ahead_and_steers():
    pg, sim, context = _pg()
    pg.set_velocity(context, 0.2, 0.0, 0.0)
    ahead = []
    t = 0.0
    while t < 6.0:
        t += 0.05
        sim.AdvanceTo(t)
        ahead.append(len(pg.planned_landings(context)))
    assert min(ahead) >= FOOTPRINTS_AHEAD - 1 and max(ahead) >= FOOTPRINTS_AHEAD
    straight = pg.footprints(context)
    assert all(abs(s.yaw) < 1e-12 for s in straight.values())
    already_planned = [s for _, s in pg.planned_landings(context)]
    pg.set_velocity(context, 0.0, 0.0, 0.3)
    # Footprints already planned are kept: the planner does not change its window.
    assert [s for _, s in pg.planned_landings(context)][: len(already_planned)] == already_planned
    sim.AdvanceTo(16.0)
    feet = pg.footprints(context)
    assert min(f.yaw for f in feet.values()) > 1.0  # it turned (0.3 rad/s, 0.24 rad per step)
    # The waist reference turns with the feet.
    yaw = math.atan2(
        _out(pg, context, "waist").rotation().matrix()[1, 0],
        _out(pg, context, "waist").rotation().matrix()[0, 0],
    )
    assert yaw > 0.5
    pg.set_velocity(context, 0.0, 0.0, 0.0)
    last = pg.planned_landings(context)[-1][0]
    sim.AdvanceTo(last + 3.0)
    assert _out(pg, context, "in_process")[0] == 0
    left, right = pg.footprints(context)["left"], pg.footprints(context)["right"]
    assert left.yaw == pytest.approx(right.yaw)  # stopped with the feet side by side


def test_limits_object_is_used(monkeypatch):
    tight = StepLimits(max_stride=0.1)
    pg = PatternGenerator(LEFT, RIGHT, com_height=0.81, limits=tight)
    context = pg.CreateDefaultContext()
    with pytest.raises(ValueError, match="max_stride 0.1"):
        pg.add_steps(context, [Footstep(0.15, -0.095, 0.0, "right")])


# --- bounds of the walking parameters (WALKING_BOUNDS) ---------------------------------

# verb -> (the bound it is checked against, the Python setter that sets the same value)
VERBS = {
    ":singlesupporttime": ("single_support", lambda pg, c, v: pg.set_timing(c, single_support=v)),
    ":doublesupporttime": ("double_support", lambda pg, c, v: pg.set_timing(c, double_support=v)),
    ":stepheight": ("step_height", lambda pg, c, v: pg.set_timing(c, step_height=v)),
    ":comheight": ("com_height", lambda pg, c, v: pg.set_model(c, com_height=v)),
    ":previewcontroltime": ("preview_time", lambda pg, c, v: pg.set_model(c, horizon=v)),
}


def _bound_text(bound) -> str:
    return rf"\[{bound.low:g}, {bound.high:g}\] {bound.unit}"


def _refused_values(bound) -> list[float]:
    """NaN, infinities and values just outside each end."""
    eps = 1e-6 * bound.high
    return [math.nan, -math.inf, math.inf, bound.low - eps, bound.high + eps, -bound.low, 10 * bound.high]


@pytest.mark.parametrize("verb", list(VERBS))
def test_each_verb_refuses_values_outside_its_bound_naming_it(verb):
    name, setter = VERBS[verb]
    bound = getattr(WALKING_BOUNDS, name)
    pg, sim, context = _pg()
    before = pg.planner(context)
    for value in _refused_values(bound):
        with pytest.raises(ValueError, match=rf"^{verb}: .*{name}.*{_bound_text(bound)}"):
            pg.parsecmd(context, f"{verb} {value!r}")
        with pytest.raises(ValueError, match=rf"{name}.*{_bound_text(bound)}"):
            setter(pg, context, value)
        assert pg.planner(context) is before  # a refused value changes nothing
    # Both ends are inside (a closed interval), through the verb and the setter.
    for value in (bound.low, bound.high):
        pg.parsecmd(context, f"{verb} {value!r}")
        setter(pg, context, value)


def test_a_refused_timing_leaves_the_walk_plannable():
    """Today's failure: ``:singlesupporttime 1e-9`` was accepted and every later step refused."""
    pg, sim, context = _pg()
    with pytest.raises(ValueError, match=r"single_support.*\[0.2, 5\] s"):
        pg.parsecmd(context, ":singlesupporttime 1e-9")
    with pytest.raises(ValueError, match=r"step_height = 2.0 m.*\[0.01, 0.3\] m"):
        pg.parsecmd(context, ":stepheight 2.0")
    pg.parsecmd(context, ":stepseq 0.1 -0.19 0")
    ((t_land, step),) = pg.planned_landings(context)
    sim.AdvanceTo(t_land - TIMING.single_support / 2)
    # Mid-swing, the foot is at the step height of the timing in force, not at 2 m.
    assert _out(pg, context, "right_foot").translation()[2] == pytest.approx(TIMING.step_height, rel=1e-3)


@pytest.mark.parametrize(("argument", "name"), [("com_height", "com_height"), ("horizon", "preview_time")])
def test_constructor_refuses_model_values_outside_their_bound(argument, name):
    bound = getattr(WALKING_BOUNDS, name)
    defaults = {"com_height": 0.81, "horizon": HORIZON}
    for value in _refused_values(bound):
        with pytest.raises(ValueError, match=rf"{name}.*{_bound_text(bound)}"):
            PatternGenerator(LEFT, RIGHT, **{**defaults, argument: value})
    for value in (bound.low, bound.high):
        pg = PatternGenerator(LEFT, RIGHT, **{**defaults, argument: value})
        controller = pg.planner(pg.CreateDefaultContext()).controller
        assert (controller.z_c if argument == "com_height" else controller.horizon) == value


@pytest.mark.parametrize("name", ["single_support", "double_support", "step_height"])
def test_constructor_timing_is_bounded(name):
    bound = getattr(WALKING_BOUNDS, name)
    for value in _refused_values(bound):
        with pytest.raises(ValueError, match=rf"StepTiming.{name}.*{_bound_text(bound)}"):
            PatternGenerator(LEFT, RIGHT, com_height=0.81, timing=StepTiming(**{name: value}))


def test_model_verbs_refused_while_walking_name_the_parameter():
    pg, sim, context = _pg()
    pg.parsecmd(context, ":stepseq 0.1 -0.19 0")
    for verb, name in ((":comheight 0.8", "com_height"), (":previewcontroltime 1.2", "preview_time")):
        with pytest.raises(ValueError, match=f"{name} can change only while standing"):
            pg.parsecmd(context, verb)


def test_a_timing_too_short_for_the_control_period_is_refused_at_the_command():
    # 0.05 s of double support is inside the bounds but gives no sample at a 0.2 s period.
    with pytest.raises(ValueError, match=r"double_support = 0.05 s gives 0 samples at dt = 0.2 s"):
        PatternGenerator(LEFT, RIGHT, com_height=0.81, dt=0.2, timing=StepTiming(double_support=0.05))


def test_initial_stance_and_stepseq_values_are_checked():
    with pytest.raises(ValueError, match="initial stance: .*min_width"):
        PatternGenerator(Footstep(0.0, -0.1, 0.0, "left"), Footstep(0.0, 0.1, 0.0, "right"), com_height=0.81)
    pg, sim, context = _pg()
    with pytest.raises(ValueError, match=r":stepseq: triple 0 y = nan: must be a finite number"):
        pg.parsecmd(context, ":stepseq 0.1 nan 0")
    with pytest.raises(ValueError, match="y = 0 says neither left nor right"):
        pg.parsecmd(context, ":stepseq 0.1 0 0")
