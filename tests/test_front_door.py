"""The front door hardened: what a script line, a served request or a Python argument may hold
(integers beyond float range, 1e400) gives the documented error, never an OverflowError; from a
``drake-sot script`` run and from a client of ``drake-sot serve`` (another process) too."""

import math
import subprocess

import numpy as np
import pytest
from served import DRAKE_SOT, REPO, start, stop

from drake_sot import validation
from drake_sot.remote import Client, RemoteError
from drake_sot.script import ScriptError, parse_line

HUGE = "1" + "0" * 400  # 10**400: an int Python reads, beyond float range (max ~1.8e308)
assert math.isinf(float("1e400")) and int(HUGE).bit_length() > 1024


# --- the script parser ----------------------------------------------------------------------


@pytest.mark.parametrize(
    "before, number",
    [
        ("run ", HUGE),
        ("sot.push taskLH ", HUGE),
        ("sot.push taskLH ", "-" + HUGE),
        ("sot.push taskLH ", "1e400"),
        ("pg.parsecmd :stepseq ", HUGE),
        ("set featureComDes.errorIN ", HUGE),
        ("set featureComDes.errorIN [3](0,", HUGE + ",0.64)"),
        ("run ", "1e400"),
    ],
)
def test_a_number_beyond_float_range_is_a_script_error_at_its_column(before, number):
    with pytest.raises(ScriptError, match="float range|finite number") as raised:
        parse_line(before + number)
    assert raised.value.column == len(before) + 1  # where the number starts


def test_the_largest_float_is_still_a_number():
    largest = int(np.finfo(float).max)  # 309 digits: what float() still reads
    command = parse_line(f"x.y {largest}")
    assert command.args == (largest,) and float(command.args[0]) == np.finfo(float).max
    with pytest.raises(ScriptError, match="float range"):
        parse_line(f"x.y {largest * 2}")


# --- validation: every helper raises its ValueError ------------------------------------------


@pytest.mark.parametrize(
    "check",
    [
        lambda v: validation.finite("g", v),
        lambda v: validation.positive("g", v),
        lambda v: validation.nonnegative("g", v),
        lambda v: validation.bounded("g", v, 0.0, 1.0),
        lambda v: validation.vector("g", [0.0, v]),
        lambda v: validation.matrix("g", [[v]]),
        lambda v: validation.per_axis("g", v, 3),
        lambda v: validation.bounds("g", [0.0], [v], 1),
        lambda v: validation.bounds("g", [-v], [0.0], 1),
    ],
)
@pytest.mark.parametrize("value", [10**400, -(10**400), 10**5000], ids=["1e400", "-1e400", "1e5000"])
def test_every_validation_helper_refuses_an_integer_beyond_float_range_with_its_value_error(check, value):
    with pytest.raises(ValueError, match="float range") as raised:
        check(value)
    assert type(raised.value) is ValueError
    assert len(str(raised.value)) < 200  # the value shown by its number of digits, not written out


def test_the_message_shows_a_huge_integer_by_its_number_of_digits():
    with pytest.raises(ValueError, match=r"g = an integer of ~401 digits: must be a number within float"):
        validation.positive("g", 10**400)
    with pytest.raises(ValueError, match=r"n = -an integer of ~5001 digits: must be an integer >= 1"):
        validation.positive_int("n", -(10**5000))


# --- drake-sot script: one line, exit 2 -------------------------------------------------------


@pytest.mark.parametrize(
    "line", [f"run {HUGE}", f"sot.push taskLH {HUGE}", "run 1e400"], ids=["run", "push", "run-float"]
)
def test_drake_sot_script_with_a_number_beyond_float_range_says_so_in_one_line(tmp_path, line):
    script = tmp_path / "huge.sot"
    script.write_text(f"# a number no float holds\n{line}\n")
    proc = subprocess.run(
        [*DRAKE_SOT, "script", str(script), "--out", str(tmp_path / "out")],
        capture_output=True,
        text=True,
        cwd=REPO,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr and len(proc.stderr.strip().splitlines()) == 1, proc.stderr
    assert "huge.sot, line 2" in proc.stderr and ("float range" in proc.stderr or "finite" in proc.stderr)


# --- a served run: an error reply, and the run goes on ----------------------------------------


@pytest.fixture(scope="module")
def server():
    proc, host, port = start("--port", "0", "--duration", "300")
    yield proc, host, port
    stop(proc)


@pytest.mark.parametrize(
    "cmd",
    [f"run {HUGE}", f"sot.push taskLH {HUGE}", "sot.push taskLH 1e400", f"taskRH.controlGain {HUGE}"],
    ids=["run", "push", "push-float", "gain"],
)
def test_a_served_line_with_a_number_beyond_float_range_is_refused_and_the_run_goes_on(server, cmd):
    proc, host, port = server
    with Client(host, port) as client:
        with pytest.raises(RemoteError, match="float range|finite"):
            client.run(cmd)
        before = client.t
        stack = client.run("sot.list").split()
        assert "taskLH" not in stack  # nothing was pushed
        while client.t < before + 0.1:  # the simulation goes on, and answers
            assert len(client.read("dyn.com")) == 3
    assert proc.poll() is None
