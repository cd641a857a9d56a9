"""A full disk while a run's artefacts are written: the files that still fit are written, one
line on stderr names those that could not be, and the command exits with 4 (UNWRITTEN)."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from drake_sot.app import cli
from drake_sot.diagrams import scenario


def _disk_full(path) -> None:
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


@pytest.mark.parametrize("writer", ["write_svg", "write_npz"])
def test_a_full_disk_costs_the_file_that_did_not_fit_and_no_other(writer, tmp_path, monkeypatch, capsys):
    """The diagram (written before the run) or the logs (the first file written after it)."""
    monkeypatch.setattr(scenario, writer, lambda *args: _disk_full(args[-1]))
    code = cli.main(["run", "reach", "--duration", "0.2", "--no-record", "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert code == cli.UNWRITTEN == 4, captured.err
    missing = tmp_path / ("reach.svg" if writer == "write_svg" else "reach.npz")
    (line,) = [line for line in captured.err.splitlines() if line.startswith("could not write")]
    assert line == f"could not write: {missing} (No space left on device, errno ENOSPC)"
    assert "Traceback" not in captured.err
    written = {"reach.svg", "reach.npz", "reach.png"} - {missing.name}
    assert {p.name for p in tmp_path.iterdir()} == written  # and no temporary left behind
    for name in written:
        assert f"wrote {tmp_path / name}" in captured.out
    if "reach.npz" in written:
        assert np.load(tmp_path / "reach.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)


def test_a_run_with_every_artefact_written_exits_0(tmp_path, capsys):
    code = cli.main(["run", "reach", "--duration", "0.1", "--no-record", "--out", str(tmp_path)])
    assert code == 0, capsys.readouterr().err
    assert "could not write" not in capsys.readouterr().err
