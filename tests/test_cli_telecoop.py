"""``drake-sot run telecooperation``: its options reach the scenario, other scenarios refuse them."""

import pytest

from drake_sot import cli
from drake_sot.diagrams import SCENARIOS


def test_leader_and_delay_are_telecooperation_options(capsys):
    assert SCENARIOS["telecooperation"].parameters == ("leader", "delay")
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "reach", "--leader", "cooperator"])
    assert exit_.value.code == 2
    assert "reach takes no --leader" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "telecooperation", "--leader", "nobody"])
    assert exit_.value.code == 2
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "telecooperation", "--delay", "nan"])
    assert exit_.value.code == 2
    assert "delay" in capsys.readouterr().err


def test_a_delay_beyond_300_ms_is_refused_by_the_scenario():
    with pytest.raises(ValueError, match="delay"):
        SCENARIOS["telecooperation"].build(None, delay=0.31)
    with pytest.raises(ValueError, match="leader"):
        SCENARIOS["telecooperation"].build(None, leader="nobody")
