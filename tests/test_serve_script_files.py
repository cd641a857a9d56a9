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

from drake_sot.remote import Client, RemoteError

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


def test_a_served_script_without_out_writes_into_a_fresh_directory_only(tmp_path):
    script = tmp_path / "served.sot"
    script.write_text(SCRIPT)
    proc, port = _serve(script)
    try:
        with Client("127.0.0.1", port) as client:
            answer = client.run("pool.writegraph graph.dot")
            for name in ("../served.sot", "sub/graph.dot", str(tmp_path / "x.dot"), ".."):
                with pytest.raises(RemoteError, match="must be a plain file name"):
                    client.run(f'pool.writegraph "{name}"')
            assert client.run("pool.writegraph graph.dot") == answer  # its own file again
    finally:
        err = _stop(proc)
    (announced,) = re.findall(r"the script writes its files \(pool\.writegraph\) into (\S+)", err)
    written = Path(answer.removeprefix("wrote "))
    assert written == Path(announced) / "graph.dot" and written.read_text().startswith("digraph")
    assert Path(announced).resolve() != tmp_path.resolve()
    assert os.listdir(tmp_path) == ["served.sot"] and script.read_text() == SCRIPT
    assert os.listdir(announced) == ["graph.dot"]  # no directory made, no other file


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
