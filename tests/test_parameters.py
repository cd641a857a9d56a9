"""Typed scenario parameters: each declaration checks its values, the command's options are
generated from the declarations, and a scenario's handles have their declared types."""

from __future__ import annotations

import dataclasses
import inspect
import subprocess
import sys
import typing

import pytest

from drake_sot.app import cli
from drake_sot.diagrams import PEERS, SCENARIOS, STUDIES
from drake_sot.diagrams.scenario import (
    Scenario,
    ScenarioHandles,
    ScenarioParameterError,
    build_scenario,
)
from drake_sot.parameters import Parameter, UndeclaredParameter, check_parameters

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]

DELAY = Parameter("delay", "float", 0.1, "a delay", minimum=0.0, maximum=0.3, unit="s")
LOSS = Parameter("loss", "float", 0.0, "a probability", minimum=0.0, maximum=1.0, maximum_excluded=True)
COUNT = Parameter("count", "int", 2, "a count", minimum=1, maximum=8)
SIDE = Parameter("side", "choice", "left", "a side", choices=("left", "right"))


# --- the declaration ---
@pytest.mark.parametrize(
    ("parameter", "value", "message"),
    [
        (DELAY, 0.31, "delay = 0.31 s: must be in [0, 0.3] s"),
        (DELAY, -0.01, "delay = -0.01 s: must be in [0, 0.3] s"),
        (DELAY, float("nan"), "delay = nan s: must be in [0, 0.3] s"),
        (DELAY, float("inf"), "delay = inf s: must be in [0, 0.3] s"),
        (DELAY, 10**400, "delay = an integer of ~401 digits s: must be in [0, 0.3] s"),
        (DELAY, "0.1", "delay = '0.1' s: must be in [0, 0.3] s"),
        (LOSS, 1.0, "loss = 1.0: must be in [0, 1)"),
        (COUNT, 9, "count = 9: must be an integer in [1, 8]"),
        (COUNT, 0, "count = 0: must be an integer >= 1"),
        (COUNT, 2.5, "count = 2.5: must be an integer >= 1"),
        (COUNT, True, "count = True: must be an integer >= 1"),
        (SIDE, "up", "side = 'up': must be one of: left, right"),
        (SIDE, None, "side = None: must be one of: left, right"),
    ],
)
def test_a_value_out_of_its_declaration_is_refused_naming_it_and_the_bounds(parameter, value, message):
    with pytest.raises(ValueError) as refused:
        parameter.check(value)
    assert str(refused.value) == message


def test_values_within_the_declaration_pass_converted():
    assert DELAY.check(0) == 0.0 and isinstance(DELAY.check(0), float)
    assert DELAY.check(0.3) == 0.3  # the bounds are inclusive
    assert LOSS.check(0.999) == 0.999
    assert COUNT.check(8.0) == 8 and isinstance(COUNT.check(8.0), int)
    assert SIDE.check("right") == "right"
    stabilizer = Parameter("stabilizer", "bool", True, "the stabilizer")
    assert stabilizer.check(False) is False
    with pytest.raises(ValueError, match="stabilizer = 0: must be True or False"):
        stabilizer.check(0)


def test_options_are_named_from_the_parameter():
    assert DELAY.option == "--delay"
    assert Parameter("stabilizer", "bool", True, "the stabilizer").option == "--no-stabilizer"
    assert Parameter("dry_run", "bool", False, "no effect").option == "--dry-run"


@pytest.mark.parametrize(
    "arguments",
    [
        {"name": "x", "kind": "float", "default": 1.0, "help": "", "maximum": 0.5},  # default refused
        {"name": "x", "kind": "float", "default": 1.0, "help": "", "choices": ("a",)},
        {"name": "x", "kind": "choice", "default": "a", "help": "", "choices": ("a",), "minimum": 0},
        {"name": "x", "kind": "choice", "default": "a", "help": ""},  # no choices
        {"name": "x", "kind": "int", "default": 1, "help": ""},  # no minimum
        {"name": "x", "kind": "str", "default": "a", "help": ""},
        {"name": "not a name", "kind": "float", "default": 1.0, "help": ""},
    ],
)
def test_a_declaration_that_contradicts_itself_is_refused(arguments):
    with pytest.raises(ValueError):
        Parameter(**arguments)


def test_check_parameters_refuses_an_undeclared_name_listing_the_declared_ones():
    with pytest.raises(UndeclaredParameter, match=r"unknown parameter 'speed'; known: delay, side"):
        check_parameters("probe", (DELAY, SIDE), {"speed": 1.0})
    assert check_parameters("probe", (DELAY, SIDE), {"delay": 0}) == {"delay": 0.0}


# --- the declarations of the package ---
RUNNABLES = {
    **{name: (s.build, s.parameters) for name, s in SCENARIOS.items()},
    **{name: (s.run, s.parameters) for name, s in STUDIES.items()},
    **{name: (s.run, s.parameters) for name, s in PEERS.items()},
}


@pytest.mark.parametrize("name", sorted(RUNNABLES))
def test_each_declared_default_is_the_builders_own(name):
    function, parameters = RUNNABLES[name]
    signature = inspect.signature(function)
    for parameter in parameters:
        assert parameter.name in signature.parameters, (name, parameter.name)
        assert signature.parameters[parameter.name].default == parameter.default, (name, parameter.name)


def test_every_declared_parameter_is_an_option_of_run_listed_in_its_help(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "--help"])
    assert exit_.value.code == 0
    shown = " ".join(capsys.readouterr().out.split())  # argparse wraps the help
    options = {p.option for _, parameters in RUNNABLES.values() for p in parameters}
    assert options >= {"--delay", "--jitter", "--loss", "--leader", "--admittance", "--transition"}
    assert options >= {"--decision", "--no-stabilizer", "--robot", "--workers"}
    for option in options:
        assert option in shown, option
    assert (
        "telecooperation, telecoop_master: one-way delay of the link; in [0, 0.3] s (default 0.14 s)" in shown
    )
    assert "walk, walk_then_interact: without the balance stabilizer (on by default)" in shown
    assert (
        "look_and_reach, reach, reach_around, telecoop_slave, telecooperation, walk, walk_long, "
        "walk_random, walk_then_interact: without the self-collision avoidance task" in shown
    )


def test_a_parameter_added_to_a_declaration_is_an_option_without_touching_the_cli(monkeypatch, capsys):
    gain = Parameter("gain", "float", 1.0, "a gain", minimum=0.0, maximum=10.0, unit="1/s")
    fake = Scenario(
        name="fake", description="a fake", build=lambda meshcat, gain=1.0: None, parameters=(gain,)
    )
    monkeypatch.setitem(cli.SCENARIOS, "fake", fake)
    called = []
    monkeypatch.setattr(
        cli, "_run_scenario", lambda scenario, args, parameters: called.append(parameters) or 0
    )
    assert cli.main(["run", "fake", "--gain", "2.5"]) == 0
    assert called == [{"gain": 2.5}]
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "fake", "--gain", "11"])
    assert exit_.value.code == 2
    assert "argument --gain: gain = 11 1/s: must be in [0, 10] 1/s" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:  # another scenario does not take it
        cli.main(["run", "reach", "--gain", "1"])
    assert exit_.value.code == 2
    assert (
        "reach takes no --gain (it takes --duration, --out, --no-record, --fixed-camera, --push, --robot, "
        "--no-self-collision)" in (capsys.readouterr().err)
    )


def test_two_declarations_of_one_name_that_differ_cannot_make_one_option():
    other = dataclasses.replace(DELAY, maximum=0.5)
    with pytest.raises(ValueError, match="parameter 'delay': b declares .* one option cannot serve both"):
        cli.distinct_parameters({"a": (DELAY,), "b": (other,)})
    assert cli.distinct_parameters({"a": (DELAY,), "b": (DELAY, SIDE)}) == {
        "delay": (DELAY, ["a", "b"]),
        "side": (SIDE, ["b"]),
    }


@pytest.mark.parametrize(
    ("argv", "line"),
    [
        (
            ["run", "telecooperation", "--delay", "0.5"],
            "drake-sot run: error: argument --delay: delay = 0.5 s: must be in [0, 0.3] s",
        ),
        (
            ["serve", "telecooperation", "--loss", "1"],
            "drake-sot serve: error: argument --loss: loss = 1: must be in [0, 1)",
        ),
    ],
)
def test_a_value_out_of_bounds_on_the_real_command_exits_2_naming_the_option_and_bounds(argv, line):
    proc = subprocess.run([*DRAKE_SOT, *argv], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2
    assert proc.stdout == ""
    assert proc.stderr.strip() == line


def test_serve_takes_the_parameters_of_the_served_scenario_only(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["serve", "telecoop_slave", "--delay", "0.1", "--port", "0"])
    assert exit_.value.code == 2
    assert "serve: telecoop_slave takes no --delay (it takes --leader, --no-self-collision)" in (
        capsys.readouterr().err
    )


def test_build_scenario_checks_the_values_before_building():
    built = []
    probe = Scenario(
        name="probe", description="", build=lambda *a, **k: built.append(k), parameters=(DELAY, SIDE)
    )
    with pytest.raises(ScenarioParameterError, match=r"^probe: delay = nan s: must be in \[0, 0.3\] s$"):
        build_scenario(probe, None, parameters={"delay": float("nan")})
    with pytest.raises(ValueError, match=r"unknown parameter 'speed'"):
        build_scenario(probe, None, parameters={"speed": 1})
    assert built == []
    build_scenario(probe, None, parameters={"delay": 0, "side": "right"})
    assert built == [{"delay": 0.0, "side": "right"}]


# --- the handles ---
def _declared_types() -> dict[str, object]:
    from drake_sot.diagrams.script_session import ScriptSession

    return typing.get_type_hints(ScenarioHandles, localns={"ScriptSession": ScriptSession})


def _is(value, hint) -> bool:
    """``value`` is of the type ``hint`` (``X | None``, ``list[X]``, ``dict[str, X]``, ``tuple[X, ...]``)."""
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (typing.Union, type(int | None)):
        return any(_is(value, arg) for arg in args)
    if hint is type(None):
        return value is None
    if origin in (list, tuple):
        return isinstance(value, origin) and all(_is(v, args[0]) for v in value)
    if origin is dict:
        return isinstance(value, dict) and all(_is(k, args[0]) and _is(v, args[1]) for k, v in value.items())
    return isinstance(value, hint)


@pytest.mark.parametrize(
    ("name", "parameters", "present"),
    [
        ("walk", {}, {"pattern_generator", "steps"}),
        (
            "walk_then_interact",
            {"decision": "remote"},
            {"decision", "pattern_generator", "admittances", "hands", "steps"},
        ),
        ("table_pounding", {"transition": 0.3}, {"schedule", "transition", "desired_force"}),
    ],
)
def test_a_scenarios_handles_are_of_their_declared_types(name, parameters, present):
    from drake_sot.systems.pattern_generator import PatternGenerator

    handles = build_scenario(SCENARIOS[name], None, parameters=parameters).extras
    hints = _declared_types()
    given = {f.name for f in dataclasses.fields(handles) if getattr(handles, f.name) not in (None, False)}
    assert given == present
    for field in dataclasses.fields(handles):
        assert _is(getattr(handles, field.name), hints[field.name]), field.name
    assert handles.pattern_generator is None or isinstance(handles.pattern_generator, PatternGenerator)
    if name == "table_pounding":
        assert handles.transition == 0.3


# --- the configurations ---
def test_the_telecooperation_timings_follow_from_its_configuration():
    from drake_sot.diagrams import telecooperation as tc

    config = tc.DEFAULT_CONFIG
    # lift 5 cm up and down at 5 cm/s from 1 s; the follower 1 s behind walks 2 m then 0.5 m at
    # 5 cm/s; then 4 s
    assert config.walk_at == pytest.approx(1.0 + 2.0)
    assert config.duration == pytest.approx(3.0 + 1.0 + 2.5 / 0.05 + 4.0)
    slower = dataclasses.replace(config, speed=0.1, path=((1.0, 0.0, 0.0),))
    assert slower.duration == pytest.approx(1.0 + 1.0 + 1.0 + 10.0 + 4.0)
    assert config.carry_joints == {
        "r_shoulder_pitch": 0.0,
        "r_elbow": -1.3,
        "l_shoulder_pitch": 0.0,
        "l_elbow": -1.3,
    }


def test_a_configuration_given_to_the_builders_reaches_their_diagrams():
    from drake_sot.diagrams import table_pounding as tp
    from drake_sot.diagrams import telecooperation as tc

    setup = tc.build(None, walk=False, config=dataclasses.replace(tc.DEFAULT_CONFIG, board_mass=3.5))
    assert setup.built.plant.GetBodyByName("board").default_mass() == pytest.approx(3.5)
    assert setup.duration == tc.DEFAULT_CONFIG.duration

    config = dataclasses.replace(tp.DEFAULT_CONFIG, force=20.0, duration=5.0, stiffness=1000.0)
    setup = tp.build(None, config=config)
    assert setup.duration == 5.0 and setup.extras.desired_force == 20.0
    plant = setup.built.plant
    context = plant.CreateDefaultContext()
    # at rest on its spring: 1 kg x 9.81 m/s² / 1000 N/m below the surface
    assert plant.GetJointByName("table_slide").get_translation(context) == pytest.approx(-9.81e-3)


def test_the_parser_built_from_a_fake_table_has_exactly_its_options():
    gain = Parameter("gain", "float", 1.0, "a gain", minimum=0.0, unit="1/s")
    fake = Scenario(name="fake", description="", build=lambda meshcat, gain=1.0, side="left": None)
    fake = dataclasses.replace(fake, parameters=(gain, SIDE))
    parser, run, _ = cli._parser(cli.runnables(scenarios={"fake": fake}, studies={}, peers={}), served={})
    args = parser.parse_args(["run", "fake", "--gain", "3", "--side", "right"])
    assert (args.scenario, args.gain, args.side) == ("fake", 3.0, "right")
    assert parser.parse_args(["run", "fake"]).gain is None  # not given: the builder's default
    assert "--delay" not in run.format_help() and "fake: a gain; >= 0 1/s (default 1 1/s)" in " ".join(
        run.format_help().split()
    )
    with pytest.raises(SystemExit):
        parser.parse_args(["run", "reach"])  # not in this table
