"""``drake-sot study``'s arguments fuzzed: ``--workers``, ``--duration`` and ``--scheduler``
given huge integers, NaN, lone surrogates, any text. A value refused is exit status 2 and one
line naming it (nothing run, no traceback); a value accepted reaches the study as given."""

from __future__ import annotations

import contextlib
import io
import math
import tempfile
from datetime import timedelta
from pathlib import Path
from unittest import mock

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from drake_sot.app import cli
from drake_sot.app import study as command
from drake_sot.diagrams.alpha_sweep import MAX_WORKERS
from drake_sot.diagrams.artifacts import Artefacts
from drake_sot.diagrams.run import MAX_DURATION
from drake_sot.diagrams.study_session import StudySession
from drake_sot.studies.catalog import STUDIES

#: Any text, lone surrogates included (what a command line decoded with surrogateescape holds).
TEXT = st.text(st.characters(codec=None, exclude_categories=()), max_size=30)
#: Numbers as text: huge integers, NaN and infinities, and near the bounds.
NUMBERS = st.one_of(
    st.integers(min_value=-(10**60), max_value=10**60).map(str),
    st.sampled_from(["nan", "NaN", "-nan", "inf", "-inf", "1e400", "9" * 5000, "0", "-0", "1e-300"]),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
)


def _run(option: str, value: str) -> tuple[int, str, list]:
    """``drake-sot study gain_sweep OPTION=VALUE``, the study replaced by a recorder: (exit
    status, stderr, the calls it got)."""
    calls = []

    def record(study, out, **kwargs):
        calls.append((study, out, kwargs))
        return StudySession({}, 0, Artefacts(), None)

    err = io.StringIO()
    with (
        mock.patch.object(command, "run_with_figures", record),
        contextlib.redirect_stderr(err),
        contextlib.redirect_stdout(io.StringIO()),
    ):
        try:
            status = cli.main(["study", "gain_sweep", f"{option}={value}"])
        except SystemExit as exit_:
            status = exit_.code
    return status, err.getvalue(), calls


def _refused_in_one_line(status: int, err: str, calls: list, name: str, value: str) -> None:
    assert status == 2 and not calls, (status, err)
    assert "Traceback" not in err
    lines = err.splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"drake-sot study: error: argument --{name}: {name} = "), (
        err
    )


@settings(max_examples=300, deadline=None, derandomize=True)
@given(value=st.one_of(NUMBERS, TEXT))
def test_workers_is_an_integer_in_its_range_or_refused_in_one_line(value):
    status, err, calls = _run("--workers", value)
    try:
        number = int(value)
    except ValueError:
        number = None
    if number is not None and 1 <= number <= MAX_WORKERS:
        assert status == 0 and calls[0][2]["workers"] == number, err
    else:
        _refused_in_one_line(status, err, calls, "workers", value)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(value=st.one_of(NUMBERS, TEXT))
def test_duration_is_a_finite_positive_number_up_to_its_maximum_or_refused_in_one_line(value):
    status, err, calls = _run("--duration", value)
    try:
        number = float(value)
    except ValueError:
        number = math.nan
    if 0.0 < number <= MAX_DURATION:
        assert status == 0 and calls[0][0].duration == number, err
    else:
        _refused_in_one_line(status, err, calls, "duration", value)


@settings(max_examples=300, deadline=None, derandomize=True)
@given(
    value=st.one_of(
        TEXT,
        NUMBERS,
        st.builds(
            lambda scheme, host, port: f"{scheme}://{host}:{port}",
            st.sampled_from(["tcp", "tls", "udp", "TCP", ""]),
            st.sampled_from(["127.0.0.1", "node-1.lab", "[::1]", "", "a b", "\udcff"]),
            st.one_of(st.integers(min_value=-5, max_value=70000).map(str), TEXT),
        ),
    )
)
def test_a_scheduler_is_a_tcp_or_tls_address_or_refused_in_one_line(value):
    status, err, calls = _run("--scheduler", value)
    scheme, _, rest = value.partition("://")
    host, _, port = rest.rpartition(":")
    valid = (
        scheme in ("tcp", "tls")
        and (host.startswith("[") or host.replace(".", "").replace("-", "").replace("_", "").isalnum())
        and host.isascii()
        and port.isascii()
        and port.isdigit()
        and len(port) <= 5
        and 1 <= int(port) <= 65535
    )
    if valid and status == 0:
        assert calls[0][2]["scheduler"] == value
    else:
        assert not valid or host.startswith("["), (value, err)
        _refused_in_one_line(status, err, calls, "scheduler", value)


@pytest.mark.parametrize(
    ("option", "value", "named"),
    [
        ("--workers", "9" * 5000, "workers = '9999"),
        ("--workers", "1" + "0" * 60, "workers = an integer of ~61 digits: must be an integer in [1, "),
        ("--duration", "nan", "duration = nan s"),
        ("--scheduler", "tcp://\udcff:8786", "scheduler = 'tcp://\\udcff:8786'"),
    ],
)
def test_a_refusal_names_the_value(option, value, named):
    status, err, calls = _run(option, value)
    _refused_in_one_line(status, err, calls, option.removeprefix("--"), value)
    assert named in err


#: Each example's bound [s]: a check of the arguments never hangs (a FIFO, a device, a slow disk).
BOUNDED = settings(max_examples=200, deadline=timedelta(seconds=5), derandomize=True)


@BOUNDED
@given(name=st.one_of(TEXT, st.sampled_from(["../x", "/dev/zero", "a\x00b", "-", "9" * 5000])))
def test_a_path_given_to_out_is_a_writable_directory_or_refused_in_one_line_leaving_nothing(name):
    """Under a fresh directory (no name reaches outside it): any text, NUL bytes and lone
    surrogates included, and an empty ``--out``; an existing file and a path under it."""
    with tempfile.TemporaryDirectory() as root:
        (Path(root) / "file").write_text("")
        for value in (f"{root}/{name}", f"{root}/file/{name}", "" if not name else f"{root}/file"):
            before = sorted(Path(root).rglob("*"))
            status, err, calls = _run("--out", value)
            if status == 0:  # a name of a directory there is or can be: under no file, no NUL
                assert value and "\x00" not in value and calls[0][1] == Path(value), (value, err)
                assert not any(p.is_file() for p in (Path(value), *Path(value).parents)), (value, err)
            else:
                assert status == 2 and not calls, (value, status, err)
                assert "Traceback" not in err
                lines = err.splitlines()
                assert len(lines) == 1 and lines[0].startswith("drake-sot study: error: --out: "), (
                    value,
                    err,
                )
            assert sorted(Path(root).rglob("*")) == before  # the check made nothing that stays


@BOUNDED
@given(name=st.one_of(TEXT, NUMBERS))
def test_a_study_name_is_one_of_the_catalog_or_refused_in_one_line(name):
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        with mock.patch.object(command, "run_with_figures") as run:
            try:
                status = cli.main(["study", "--", name])
            except SystemExit as exit_:
                status = exit_.code
    if name in STUDIES:
        assert run.called
        return
    assert status == 2 and not run.called, (name, err.getvalue())
    lines = err.getvalue().splitlines()
    assert len(lines) == 1 and lines[0].startswith("drake-sot study: error: "), lines
