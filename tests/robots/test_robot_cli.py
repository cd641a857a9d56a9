"""``drake-sot list --robots`` and ``--robot NAME``: what they print and refuse."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from robot_data import robot_or_skip

from drake_sot.app import cli
from drake_sot.robots import catalog


@pytest.fixture
def without_robot_data(monkeypatch, tmp_path):
    """example-robot-data as if it were not installed (the descriptions' cache cleared around)."""
    monkeypatch.setenv(catalog.DATA_ENV, str(tmp_path / "absent"))
    catalog.talos.cache_clear()
    catalog.g1.cache_clear()
    yield
    catalog.talos.cache_clear()
    catalog.g1.cache_clear()


def test_list_robots_names_each_robot(capsys):
    assert cli.main(["list", "--robots"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == sorted(catalog.ROBOTS)


def test_list_robots_without_the_models_says_how_to_install(without_robot_data, capsys):
    assert cli.main(["list", "--robots"]) == 0
    out = capsys.readouterr().out
    assert "embedded" in out and out.count("pip install 'drake_sot[robots]'") == 2


def test_robot_without_the_models_is_refused_with_the_install_command(without_robot_data, capsys, tmp_path):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["run", "reach", "--robot", "talos", "--out", str(tmp_path / "out")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "--robot talos" in err and "pip install 'drake_sot[robots]'" in err
    assert not (tmp_path / "out" / "reach.npz").exists()  # nothing was built nor simulated


def test_robot_on_a_scenario_that_takes_none_is_refused(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["run", "look_and_reach", "--robot", "embedded"])
    assert exit_info.value.code == 2
    assert "look_and_reach takes no --robot" in capsys.readouterr().err


def test_unknown_robot_is_refused_with_the_known_ones(capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["run", "reach", "--robot", "asimo"])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "asimo" in err and "talos" in err and "g1" in err


def test_serve_refuses_a_robot_before_binding(without_robot_data, capsys):
    for argv, message in (
        (["serve", "look_and_reach", "--robot", "embedded"], "look_and_reach takes no --robot"),
        (["serve", "reach", "--robot", "g1"], "pip install 'drake_sot[robots]'"),
    ):
        with pytest.raises(SystemExit) as exit_info:
            cli.main(argv)
        assert exit_info.value.code == 2
        err = capsys.readouterr().err
        assert message in err and "serving on" not in err


@pytest.mark.parametrize(
    "argv", [["run", "reach"], ["script", str(Path(__file__).parents[2] / "examples" / "paper_III_B.sot")]]
)
def test_run_and_script_take_a_robot(argv, tmp_path, capsys):
    robot_or_skip("talos")
    code = cli.main([*argv, "--robot", "talos", "--duration", "0.3", "--no-record", "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    (npz,) = tmp_path.glob("*.npz")
    q = np.load(npz)["q"]
    assert q.shape[1] == 7 + 30  # TALOS's floating base and 30 moving joints (grippers frozen)
    # TALOS's pelvis height in half-sitting (its SRDF: 1.01927 m), not the embedded robot's 0.649 m.
    assert q[-1, 6] == pytest.approx(1.019, abs=0.01)
