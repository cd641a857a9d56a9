"""A served script's files: without --out, ``pool.writegraph`` writes into a fresh directory
(named on stderr at start), never the working directory; a client can write only a plain file
name there, and never replace a file the session did not write (the served script itself)."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from drake_sot.diagrams.script_session import MAX_OUTPUT_FILES
from drake_sot.remote import Client, RemoteError
from drake_sot.remote.shell import execute

DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]
SCRIPT = "new FeatureCoM featureCom\nnew Task taskCom\ntaskCom.add featureCom\nsot.push taskCom\n"


def _serve(script: Path, *args: str) -> tuple[subprocess.Popen, int]:
    proc = subprocess.Popen(
        [*DRAKE_SOT, "serve", str(script), "--port", "0", "--duration", "60", *args],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=script.parent,
    )
    first = proc.stdout.readline()
    match = re.fullmatch(r"serving on 127\.0\.0\.1:(\d+)\n", first)
    if match is None:
        proc.kill()
        pytest.fail(f"first line {first!r}; stderr: {proc.stderr.read()}")
    return proc, int(match.group(1))


def _stop(proc: subprocess.Popen) -> str:
    """Stop the server; its stderr."""
    proc.terminate()
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        _, err = proc.communicate()
    return err


def _announced(proc: subprocess.Popen) -> Path:
    """The fresh directory a served script writes into, named on stderr before the address."""
    line = proc.stderr.readline()
    match = re.fullmatch(
        r"the script writes its files \(pool\.writegraph\) into (\S+) \(removed when the server stops\)\n",
        line,
    )
    assert match is not None, line
    return Path(match.group(1))


def test_a_served_script_without_out_writes_into_a_fresh_directory_only(tmp_path):
    script = tmp_path / "served.sot"
    script.write_text(SCRIPT)
    proc, port = _serve(script)
    try:
        announced = _announced(proc)
        with Client("127.0.0.1", port) as client:
            answer = client.run("pool.writegraph graph.dot")
            for name in ("../served.sot", "sub/graph.dot", str(tmp_path / "x.dot"), ".."):
                with pytest.raises(RemoteError, match="must be a plain file name"):
                    client.run(f'pool.writegraph "{name}"')
            assert client.run("pool.writegraph graph.dot") == answer  # its own file again
            written = Path(answer.removeprefix("wrote "))
            assert written == announced / "graph.dot" and written.read_text().startswith("digraph")
            assert announced.resolve() != tmp_path.resolve()
            assert os.listdir(announced) == ["graph.dot"]  # no directory made, no other file
    finally:
        _stop(proc)
    assert os.listdir(tmp_path) == ["served.sot"] and script.read_text() == SCRIPT
    assert not announced.exists()  # removed with the server


def test_a_served_script_writes_a_bounded_number_of_files(tmp_path):
    """A client naming new files fills no disk: the session writes at most MAX_OUTPUT_FILES, and
    rewrites those; the SVG's stand-in .dot (no renderer) counts and replaces nothing."""
    script = tmp_path / "served.sot"
    script.write_text(SCRIPT)
    proc, port = _serve(script)
    try:
        announced = _announced(proc)
        (announced / "other.dot").write_text("not the session's")
        with Client("127.0.0.1", port) as client:
            with pytest.raises(RemoteError, match="'other.dot': .* exists and this session did not write it"):
                client.run("pool.writegraph other.svg")
            for k in range(MAX_OUTPUT_FILES):
                client.run(f"pool.writegraph g{k}.dot")
            with pytest.raises(
                RemoteError, match=f"wrote {MAX_OUTPUT_FILES} files already, the most it writes"
            ):
                client.run("pool.writegraph one_more.dot")
            assert client.run("pool.writegraph g0.dot") == f"wrote {announced / 'g0.dot'}"
            assert len(os.listdir(announced)) == MAX_OUTPUT_FILES + 1  # and other.dot, untouched
            assert (announced / "other.dot").read_text() == "not the session's"
    finally:
        _stop(proc)
    assert not announced.exists()


def test_a_served_script_never_replaces_a_file_it_did_not_write(tmp_path):
    """With --out the script's own directory, the script is a file the session did not write."""
    script = tmp_path / "served.sot"
    script.write_text(SCRIPT)
    proc, port = _serve(script, "--out", str(tmp_path))
    try:
        with Client("127.0.0.1", port) as client:
            with pytest.raises(
                RemoteError, match="'served.sot': .* exists and this session did not write it"
            ):
                client.run("pool.writegraph served.sot")
            assert client.run("pool.writegraph graph.dot") == f"wrote {tmp_path / 'graph.dot'}"
    finally:
        _stop(proc)
    assert script.read_text() == SCRIPT


def test_a_served_script_that_cannot_bind_leaves_no_directory_behind(tmp_path, monkeypatch, capsys):
    """The fresh directory of a script's files is made once the port is bound, not before."""
    from drake_sot.app import cli

    script = tmp_path / "served.sot"
    script.write_text(SCRIPT)
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(SystemExit) as exited:
            cli.main(["serve", str(script), "--port", str(taken.getsockname()[1])])
    assert exited.value.code == 2 and "serve:" in capsys.readouterr().err
    assert os.listdir(temporary) == []


# --- a client's run FILE: nothing of a file it was not given comes back ------------------------


@pytest.fixture(scope="module")
def served_dir(tmp_path_factory):
    """A served script, and its directory, where the tests put the files a client names."""
    directory = tmp_path_factory.mktemp("served")
    script = directory / "served.sot"
    script.write_text(SCRIPT)
    proc, port = _serve(script, "--duration", "600")
    with Client("127.0.0.1", port) as client:
        yield directory, client
    _stop(proc)


def _refusal(client: Client, line: str) -> str:
    with pytest.raises(RemoteError) as refused:
        client.run(line)
    return str(refused.value)


def test_a_client_cannot_tell_a_file_that_is_not_a_script_from_no_file(served_dir):
    directory, client = served_dir
    (directory / "victim.txt").write_text("precious words\n")
    (directory / "victim.sot").write_text("precious words\n")  # not a script: a line out of the grammar
    (directory / "binary.sot").write_bytes(b"\xff\xfeprecious\n")
    refusals = {
        name: _refusal(client, f"run {name}").replace(name, "NAME")
        for name in ("victim.txt", "missing.txt", "victim.sot", "missing.sot", "binary.sot", "../served.sot")
    }
    assert len(set(refusals.values())) == 1, refusals  # one line, whatever the file is or is not
    assert (
        "precious" not in refusals["victim.txt"] and "no script to run by that name" in refusals["victim.txt"]
    )


def test_a_client_runs_a_script_of_the_directory_and_a_refused_command_is_named_by_its_rank(served_dir):
    directory, client = served_dir
    (directory / "gain.sot").write_text("# sets a gain\ntaskCom.controlGain 2\n")
    assert client.run("run gain.sot") == ""
    assert float(client.run("get taskCom.controlGain")) == 2.0
    (directory / "half.sot").write_text("taskCom.controlGain 3\nvsecretname.controlGain 1\n")
    refused = _refusal(client, "run half.sot")
    assert "its command 2 of 2 was refused, after 1 acted" in refused and "vsecretname" not in refused
    assert float(client.run("get taskCom.controlGain")) == 3.0  # the first acted, as it says


_MARKER = st.from_regex(r"v[a-z0-9]{11}", fullmatch=True)  # a name a script line could hold
_TEMPLATES = (
    "{m}",
    "new Task {m}",
    "{m}.controlGain 3",
    "taskCom.controlGain {m}",
    "sot.push {m}",
    "set {m}.sdes 1",
    "get {m}.error",
    "run {m}.sot",
    "set featureCom.sdes [3](0,{m},1)",
    '"{m}',
    "plug {m}.a {m}.b",
    "pool.writegraph {m}/x.dot",
)


@st.composite
def _secret_files(draw):
    """A file name, and a content hiding a marker in a line the script dialect may quote back."""
    marker = draw(_MARKER)
    lines = draw(st.lists(st.text(max_size=30).filter(lambda t: "\n" not in t and "\r" not in t), max_size=3))
    lines.insert(draw(st.integers(0, len(lines))), draw(st.sampled_from(_TEMPLATES)).format(m=marker))
    before = draw(st.lists(st.sampled_from(["taskCom.controlGain 2", "# a comment", ""]), max_size=2))
    content = "\n".join([*before, *lines]).encode("utf-8", "surrogatepass")
    if draw(st.booleans()):
        content = draw(st.binary(max_size=20)) + content
    stem = draw(st.from_regex(r"[A-Za-z0-9_][A-Za-z0-9_.-]{0,15}", fullmatch=True))
    suffix = draw(st.sampled_from([".sot", ".txt", ""]))
    return stem + suffix, content, marker


@settings(max_examples=60, deadline=10_000, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(file=_secret_files(), via_shell=st.booleans())
def test_no_reply_to_a_clients_run_holds_what_the_file_holds(served_dir, file, via_shell):
    directory, client = served_dir
    name, content, marker = file
    assume(name != "served.sot")
    (directory / name).write_bytes(content)
    try:
        line = f'run "{name}"'
        if via_shell:
            reply = execute(client, line)
        else:
            try:
                reply = client.run(line)
            except RemoteError as refused:
                reply = str(refused)
    finally:
        (directory / name).unlink()
    assert marker not in reply, (name, content, reply)
    shown = [text.strip() for text in content.decode("utf-8", "replace").splitlines()]
    assert not [text for text in shown if len(text) >= 8 and text not in line and text in reply], reply
