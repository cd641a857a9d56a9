"""Bad values given to the builders never reach a Drake assertion (which raises SystemExit
and ends the interpreter): each is refused with a ValueError naming it.

The probes of the other modules live beside their tests (test_linalg, test_admittance,
systems/test_task_and_sot, systems/test_pattern_generator, test_generalized_projector,
test_cli, ...); this file holds those of the diagram builders.
"""

from __future__ import annotations

import math

import pytest

from drake_sot.diagrams.humanoid import HumanoidSoTBuilder
from drake_sot.diagrams.torque_humanoid import TorqueHumanoidBuilder

BAD_TIMES = [math.nan, math.inf, -math.inf, 0.0, -1.0, "0.005"]


@pytest.mark.parametrize("builder", [HumanoidSoTBuilder, TorqueHumanoidBuilder])
@pytest.mark.parametrize("value", BAD_TIMES)
@pytest.mark.parametrize("argument", ["control_period", "time_step"])
def test_builders_refuse_a_bad_period_by_name(builder, argument, value):
    with pytest.raises(ValueError, match=f"{argument} = "):
        builder(**{argument: value})


@pytest.mark.parametrize("value", [math.nan, math.inf, 0.0, -0.01])
def test_build_refuses_a_bad_log_period(value):
    b = HumanoidSoTBuilder()
    b.add_posture_task("taskPosture")
    with pytest.raises(ValueError, match="log_period = "):
        b.build(stack=["taskPosture"], log_period=value)


@pytest.mark.parametrize("margin", [math.nan, math.inf, -0.01])
def test_joint_limits_task_refuses_a_bad_margin(margin):
    """A NaN margin used to be accepted: the task's rows then never activated."""
    b = HumanoidSoTBuilder()
    with pytest.raises(ValueError, match="margin = "):
        b.add_joint_limits_task("taskJL", margin=margin)


def test_joint_limits_task_refuses_a_margin_wider_than_a_joint_range():
    b = HumanoidSoTBuilder()
    with pytest.raises(ValueError, match="margin = 2.0: must leave room"):
        b.add_joint_limits_task("taskJL", margin=2.0)


@pytest.mark.parametrize("builder", [HumanoidSoTBuilder, TorqueHumanoidBuilder])
@pytest.mark.parametrize("name", ["state", "errors", "status", "shortfall", "saturation"])
def test_a_log_cannot_take_the_name_of_a_builder_log(builder, name):
    b = builder()
    with pytest.raises(ValueError, match=f"a log named {name!r} exists already"):
        b.log(name, b.dyn.GetOutputPort("com"))


@pytest.mark.parametrize("value", [math.nan, math.inf, -0.1])
def test_table_pounding_refuses_a_bad_transition_from_python(value):
    """The command line refuses it at parse time; a Python caller gets the same check."""
    from drake_sot.diagrams import table_pounding

    with pytest.raises(ValueError, match="transition = "):
        table_pounding.build(None, transition=value)
