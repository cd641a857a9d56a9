"""A full disk while a run's artefacts are written: the files that still fit are written, one
line on stderr names those that could not be, and the command exits with 4 (UNWRITTEN). No
Graphviz renderer: the pictures are written as Graphviz source, one line says so, the run exits 0."""

from __future__ import annotations

import errno
import os
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from drake_sot.app import cli
from drake_sot.diagrams import artifacts, scenario

ARTEFACTS = {"reach.svg", "reach_drake.svg", "reach.npz", "reach.png"}


def _disk_full(path) -> None:
    raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))


@pytest.mark.parametrize(
    ("writer", "file"),
    [("write_graph", "reach.svg"), ("write_svg", "reach_drake.svg"), ("write_npz", "reach.npz")],
)
def test_a_full_disk_costs_the_file_that_did_not_fit_and_no_other(
    writer, file, tmp_path, monkeypatch, capsys
):
    """A diagram (written before the run) or the logs (the first file written after it)."""
    monkeypatch.setattr(scenario, writer, lambda *args: _disk_full(args[-1]))
    code = cli.main(["run", "reach", "--duration", "0.2", "--no-record", "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert code == cli.UNWRITTEN == 4, captured.err
    missing = tmp_path / file
    (line,) = [line for line in captured.err.splitlines() if line.startswith("could not write")]
    assert line == f"could not write: {missing} (No space left on device, errno ENOSPC)"
    assert "Traceback" not in captured.err
    written = ARTEFACTS - {missing.name}
    assert {p.name for p in tmp_path.iterdir()} == written  # and no temporary left behind
    for name in written:
        assert f"wrote {tmp_path / name}" in captured.out
    if "reach.npz" in written:
        assert np.load(tmp_path / "reach.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)


def test_a_run_with_every_artefact_written_exits_0(tmp_path, capsys):
    code = cli.main(["run", "reach", "--duration", "0.1", "--no-record", "--out", str(tmp_path)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "could not write" not in captured.err and "not rendered" not in captured.err
    assert {p.name for p in tmp_path.iterdir()} == ARTEFACTS
    for picture in ("reach.svg", "reach_drake.svg"):
        assert ET.parse(tmp_path / picture).getroot().tag == "{http://www.w3.org/2000/svg}svg"


def _renderers_hidden(monkeypatch, tmp_path, *programs: str):
    """PATH holds only ``programs`` (each ``name=target``, a link to ``target``) and the
    interpreter's scripts directory (where pip put graphviz-pure) is out of reach."""
    path = tmp_path / "bin"
    path.mkdir()
    for program in programs:
        name, target = program.split("=")
        (path / name).symlink_to(target)
    monkeypatch.setenv("PATH", str(path))
    monkeypatch.setattr(artifacts.sysconfig, "get_path", lambda name: str(path))


def test_without_a_renderer_the_run_writes_every_artefact_and_says_so_in_one_line(
    tmp_path, monkeypatch, capsys
):
    """No graphviz-pure and no dot: the pictures are written as their Graphviz source, the other
    artefacts as usual, one line says which pictures and how to get a renderer, and it exits 0."""
    assert artifacts.graphviz_renderer() is not None  # the run below differs by hiding it
    out = tmp_path / "out"
    _renderers_hidden(monkeypatch, tmp_path)
    assert artifacts.graphviz_renderer() is None
    code = cli.main(["run", "reach", "--duration", "0.2", "--no-record", "--out", str(out)])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "Traceback" not in captured.err and "could not write" not in captured.err
    (line,) = [line for line in captured.err.splitlines() if "not rendered" in line]
    assert str(out / "reach.svg") in line and str(out / "reach_drake.svg") in line
    assert "pip install graphviz-pure" in line
    assert {p.name for p in out.iterdir()} == {"reach.dot", "reach_drake.dot", "reach.npz", "reach.png"}
    for source in ("reach.dot", "reach_drake.dot"):
        assert (out / source).read_text().startswith("digraph")
        assert f"wrote {out / source}" in captured.out
    assert np.load(out / "reach.npz")["time"][-1] == pytest.approx(0.2, abs=0.006)


def test_graphviz_dot_renders_when_graphviz_pure_is_missing(tmp_path, monkeypatch, capsys):
    """Only a program named dot on PATH (here graphviz-pure under that name): it renders."""
    pure = artifacts.graphviz_renderer()
    assert pure is not None and os.path.basename(pure) == "graphviz-pure"
    out = tmp_path / "out"
    _renderers_hidden(monkeypatch, tmp_path, f"dot={pure}")
    assert artifacts.graphviz_renderer() == str(tmp_path / "bin" / "dot")
    code = cli.main(["run", "reach", "--duration", "0.1", "--no-record", "--out", str(out)])
    assert code == 0, capsys.readouterr().err
    assert {p.name for p in out.iterdir()} == ARTEFACTS


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
