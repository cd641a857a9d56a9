"""``drake-sot run telecooperation``: its options reach the scenario, other scenarios refuse them."""

import pytest

from drake_sot.app import cli
from drake_sot.diagrams import SCENARIOS


def test_leader_delay_admittance_jitter_loss_and_self_collision_are_telecooperation_options():
    declared = SCENARIOS["telecooperation"].parameters
    assert tuple(p.name for p in declared) == (
        "leader",
        "delay",
        "admittance",
        "jitter",
        "loss",
        "self_collision",
    )
    assert tuple(p.name for p in SCENARIOS["telecoop_slave"].parameters) == ("leader", "self_collision")


def test_no_self_collision_reaches_both_telecooperation_scenarios(monkeypatch):
    """``--no-self-collision`` on the command line reaches each scenario's build as
    ``self_collision=False`` (what the build does with it: ``test_telecooperation_stack.py``)."""
    called = []
    monkeypatch.setattr(
        cli, "_run_scenario", lambda scenario, args, parameters: called.append(parameters) or 0
    )
    for name in ("telecooperation", "telecoop_slave"):
        assert cli.main(["run", name, "--no-self-collision"]) == 0
    assert [c["self_collision"] for c in called] == [False, False]


@pytest.mark.parametrize(
    "argv, named",
    [
        (["run", "reach", "--leader", "cooperator"], "reach takes no --leader"),
        (["run", "telecooperation", "--leader", "nobody"], "--leader: invalid choice: 'nobody'"),
        (["run", "telecooperation", "--delay", "nan"], "delay"),
        (["run", "reach", "--admittance", "weighted"], "reach takes no --admittance"),
        (["run", "telecooperation", "--admittance", "heavy"], "--admittance: invalid choice: 'heavy'"),
        (["run", "reach", "--jitter", "0.01"], "reach takes no --jitter"),
        (["run", "reach", "--loss", "0.1"], "reach takes no --loss"),
        (["run", "telecooperation", "--loss", "-0.1"], "loss = -0.1"),
        (["run", "telecooperation", "--jitter", "nan"], "jitter"),
    ],
)
def test_telecooperation_options_are_checked(argv, named, capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(argv)
    assert exit_.value.code == 2
    assert named in capsys.readouterr().err


def test_a_delay_beyond_300_ms_is_refused_by_the_scenario():
    with pytest.raises(ValueError, match="delay"):
        SCENARIOS["telecooperation"].build(None, delay=0.31)
    with pytest.raises(ValueError, match="leader"):
        SCENARIOS["telecooperation"].build(None, leader="nobody")
    with pytest.raises(ValueError, match="admittance = 'heavy'"):
        SCENARIOS["telecooperation"].build(None, admittance="heavy")


def test_a_link_value_the_channel_refuses_is_a_usage_error_naming_it(tmp_path, capsys):
    # Each one's bounds are refused at parse time (exit 2 naming the option and the bounds);
    # delay + jitter beyond 0.3 s is refused by LinkConfig when the scenario is built: exit 2,
    # nothing simulated.
    for argv, named in (
        (["--loss", "1"], "argument --loss: loss = 1: must be in [0, 1)"),
        (["--delay", "0.31"], "argument --delay: delay = 0.31 s: must be in [0, 0.3] s"),
    ):
        with pytest.raises(SystemExit) as exit_:
            cli.main(["run", "telecooperation", *argv, "--no-record", "--out", str(tmp_path)])
        assert exit_.value.code == 2, argv
        assert named in capsys.readouterr().err, argv
    code = cli.main(
        [
            "run",
            "telecooperation",
            "--delay",
            "0.2",
            "--jitter",
            "0.15",
            "--no-record",
            "--out",
            str(tmp_path),
        ]
    )
    assert code == 2
    assert "LinkConfig.jitter = 0.15 s: must be in [0, 0.1" in capsys.readouterr().err
    assert not (tmp_path / "telecooperation.npz").exists()


def test_jitter_and_loss_reach_both_directions_of_the_channel():
    from drake_sot.systems.channel import Channel

    setup = SCENARIOS["telecooperation"].build(None, delay=0.1, jitter=0.02, loss=0.25)
    (channel,) = [s for s in setup.built.diagram.GetSystems() if isinstance(s, Channel)]
    for config, seed in ((channel.configs["forward"], 0), (channel.configs["backward"], 1)):
        assert (config.delay, config.jitter, config.loss, config.seed) == (0.1, 0.02, 0.25, seed)


# --- two-process mode: serve telecoop_slave, run telecoop_master --connect HOST:PORT ---


def test_connect_is_telecoop_masters_and_it_needs_it(capsys):
    for argv, named in (
        (["run", "reach", "--connect", "127.0.0.1:7777"], "reach takes no --connect"),
        (["run", "telecoop_master"], "needs --connect HOST:PORT"),
        (
            ["run", "telecoop_master", "--connect", "127.0.0.1:7777", "--no-stabilizer"],
            "takes no --no-stabilizer",
        ),
        (["run", "telecoop_master", "--connect", "nowhere"], "expected HOST:PORT"),
        (
            ["run", "telecoop_master", "--connect", "127.0.0.1:7777", "--admittance", "weighted"],
            "takes no --admittance",
        ),
        (["run", "telecoop_master", "--connect", "127.0.0.1:70000"], "expected HOST:PORT"),
        (["serve", "reach", "--leader", "cooperator", "--port", "0"], "reach takes no --leader"),
    ):
        with pytest.raises(SystemExit) as exit_:
            cli.main(argv)
        assert exit_.value.code == 2, argv
        assert named in capsys.readouterr().err, argv


def test_the_two_halves_are_listed(capsys):
    assert cli.main(["list"]) == 0
    listed = capsys.readouterr().out
    assert "telecoop_slave" in listed and "telecoop_master" in listed


def test_a_master_without_its_slave_fails_to_connect_and_says_where(tmp_path, capsys):
    import socket

    with socket.socket() as probe:  # a loopback port nobody listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    assert cli.main(["run", "telecoop_master", "--connect", f"127.0.0.1:{port}", "--out", str(tmp_path)]) == 1
    assert f"cannot connect to 127.0.0.1:{port}" in capsys.readouterr().err


def test_a_master_delay_under_one_control_period_is_refused_before_connecting(capsys):
    with pytest.raises(SystemExit) as exit_:
        cli.main(["run", "telecoop_master", "--connect", "127.0.0.1:9", "--delay", "0.003"])
    assert exit_.value.code == 2
    assert "delay - jitter = 0.003 - 0 = 0.003 s: the two-process link needs at least one period" in (
        capsys.readouterr().err
    )


def test_the_slave_declares_what_the_master_writes_and_nothing_of_the_master():
    setup = SCENARIOS["telecoop_slave"].build(None)
    remote = setup.built.remote
    assert remote is not None and remote.get_name() == "remote"
    # one signal per quantity, by name, with its size and units (names, not positions, cross the processes)
    declared = {n: (w.size, w.units) for n, w in remote.writables.items() if not n.endswith(".position_des")}
    assert declared == {
        "remote.right_hand_force": (3, "N, world axes"),
        "remote.left_hand_force": (3, "N, world axes"),
        "remote.head": (2, "rad, yaw then pitch"),
        "remote.gripper": (1, "rad, the gripper joints' angle"),
    }
    assert setup.extras.wait_for_client is True and setup.extras.paced_by_client is True
    assert (setup.extras.channel, setup.extras.master, setup.extras.operator) == (None, None, None)
    names = {s.get_name() for s in setup.built.diagram.GetSystems()}
    assert "hand_positions" in names and "master" not in names and "channel" not in names
