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


def test_a_full_disk_costs_the_study_its_figures_and_not_its_table(tmp_path, monkeypatch):
    """The sweep's grid does not fit: the runs' table (written as the runs finished) is kept, and
    the run says which files it could not write."""
    from drake_sot.diagrams import alpha_sweep, alpha_sweep_plots

    monkeypatch.setattr(alpha_sweep_plots, "write_npz", lambda arrays, path: _disk_full(path))
    artefacts = alpha_sweep.run(tmp_path, grid=(0.0,), duration=0.1, workers=1)
    assert artefacts.unwritten == {str(tmp_path / "alpha_sweep.*"): "No space left on device, errno ENOSPC"}
    assert "npz" not in artefacts.files and "png" not in artefacts.files
    assert artefacts.files["table"].stat().st_size > 0
    assert "alpha_sweep.npz" not in {p.name for p in tmp_path.iterdir()}


def _unwritten_output(**fields):
    return {"unwritten": {"out/x.npz": "No space left on device, errno ENOSPC"}, **fields}


def test_a_study_with_an_unwritten_file_exits_4_and_names_it(tmp_path, monkeypatch, capsys):
    from dataclasses import replace

    from drake_sot.diagrams.artifacts import Artefacts

    study = replace(cli.STUDIES["alpha_sweep"], run=lambda out, **kw: Artefacts(**_unwritten_output()))
    monkeypatch.setitem(cli.STUDIES, "alpha_sweep", study)
    code = cli.main(["run", "alpha_sweep", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == cli.UNWRITTEN, err
    assert "could not write: out/x.npz (No space left on device, errno ENOSPC)" in err


def test_a_peer_run_with_an_unwritten_file_exits_4_and_names_it(tmp_path, monkeypatch, capsys):
    from dataclasses import replace

    from drake_sot.diagrams.run import RunResult
    from drake_sot.diagrams.telecoop_master import MasterOutput

    def run(host, port, out, **kwargs):
        return MasterOutput(**_unwritten_output(result=RunResult(end_time=1.0), arrays={}, files={}))

    monkeypatch.setitem(cli.PEERS, "telecoop_master", replace(cli.PEERS["telecoop_master"], run=run))
    code = cli.main(["run", "telecoop_master", "--connect", "127.0.0.1:9", "--out", str(tmp_path)])
    err = capsys.readouterr().err
    assert code == cli.UNWRITTEN, err
    assert "could not write: out/x.npz (No space left on device, errno ENOSPC)" in err
