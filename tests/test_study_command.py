"""``drake-sot study`` in-process: the listing, the refusals (exit 2, nothing run), and the
push-recovery survival map read off a table's rows."""

from __future__ import annotations

import errno
import os

import numpy as np
import pytest

from drake_sot.app import cli
from drake_sot.diagrams import delay_sweep_plots, study_session
from drake_sot.diagrams.push_recovery_plots import survival_map, write_figures
from drake_sot.diagrams.study_runs import TARGETS
from drake_sot.studies.catalog import DELAY_SWEEP, PUSH_RECOVERY, STUDIES
from drake_sot.studies.description import check_study
from drake_sot.studies.runner import StudyOutcome


def test_the_listing_names_every_study_its_target_and_its_runs(capsys):
    assert cli.main(["study", "--list"]) == 0
    out = capsys.readouterr().out
    assert "alpha_sweep" in out and "(36 runs of priority_switching)" in out
    assert "push_recovery" in out and f"({2 * 4 * 4 * 6} runs of walk)" in out
    assert "gain_sweep" in out and "(6 runs of reach)" in out
    assert "delay_sweep" in out and "(24 runs of telecooperation_standing)" in out


@pytest.mark.parametrize("name", sorted(STUDIES))
def test_every_study_is_accepted_by_its_targets_declarations(name):
    study = STUDIES[name]
    assert check_study(study, TARGETS[study.scenario].parameters)


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["study"], "give a study's NAME"),
        (
            ["study", "nope"],
            "study 'nope': unknown; one of: alpha_sweep, delay_sweep, gain_sweep, push_recovery",
        ),
        (["study", "alpha_sweep", "--workers", "0"], "workers = 0: must be an integer >= 1"),
        (["study", "alpha_sweep", "--duration", "nan"], "duration = nan"),
        (["study", "alpha_sweep", "--scheduler", "tcp://127.0.0.1:1", "--workers", "2"], "--workers is for"),
    ],
)
def test_bad_arguments_exit_2_with_one_line_and_nothing_run(tmp_path, capsys, argv, message):
    with pytest.raises(SystemExit) as exit_:
        cli.main([*argv, "--out", str(tmp_path)])
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_the_survival_map_keeps_per_cell_the_largest_force_survived(tmp_path):
    def row(stabilizer, time, direction, force, survived, status="ok"):
        return {
            "stabilizer": stabilizer,
            "push_time": time,
            "push_direction": direction,
            "push_force": force,
            "survived": survived,
            "status": status,
        }

    rows = dict(
        enumerate(
            [
                row(True, 2.3, 90.0, 800.0, False),
                row(True, 2.3, 90.0, 400.0, True),
                row(True, 2.3, 90.0, 600.0, False),
                row(True, 2.3, 90.0, 500.0, True),
                row(False, 2.3, 90.0, 800.0, False),
                row(False, 2.3, 90.0, 400.0, False),
                row(True, 2.1, 0.0, 900.0, True, status="failed"),  # a failed run says nothing
            ]
        )
    )
    survival = survival_map(PUSH_RECOVERY, rows)
    largest = survival["largest_survived"]
    assert largest.shape == (2, 4, 4)
    i, j = list(survival["push_time"]).index(2.3), list(survival["push_direction"]).index(90.0)
    assert largest[0, i, j] == 500.0  # stabilizer on (the first of the axis)
    assert largest[1, i, j] == 0.0  # nothing survived: the bisection's low
    assert np.count_nonzero(largest) == 1
    files = write_figures(PUSH_RECOVERY, rows, tmp_path)
    assert files["png"].stat().st_size > 1000
    np.testing.assert_array_equal(np.load(files["npz"])["largest_survived"], largest)


def test_the_delay_sweep_figure_has_one_curve_per_jitter_and_loss_over_increasing_delays(tmp_path):
    def row(jitter, loss, delay, error, status="ok"):
        metrics = {"tracking_error_rms": error, "tracking_error_max": 2 * error, "force_error_rms": 3.0}
        return {"jitter": jitter, "loss": loss, "delay": delay, "status": status, "survived": delay < 0.2} | (
            metrics | {"force_ratio": 0.5}
        )

    rows = dict(
        enumerate(
            [
                row(0.0, 0.0, 0.2, 0.03),
                row(0.0, 0.0, 0.0, 0.01),
                row(0.04, 0.3, 0.1, 0.02),
                row(0.0, 0.0, 0.1, 0.02),
                row(0.04, 0.3, 0.0, 0.9, status="failed"),  # a failed run says nothing
            ]
        )
    )
    curves = delay_sweep_plots.curves(rows)
    assert list(curves) == [(0.0, 0.0), (0.04, 0.3)]
    np.testing.assert_array_equal(curves[(0.0, 0.0)]["delay"], [0.0, 0.1, 0.2])
    np.testing.assert_array_equal(curves[(0.0, 0.0)]["tracking_error_rms"], [0.01, 0.02, 0.03])
    np.testing.assert_array_equal(curves[(0.0, 0.0)]["survived"], [1.0, 1.0, 0.0])
    np.testing.assert_array_equal(curves[(0.04, 0.3)]["delay"], [0.1])
    files = delay_sweep_plots.write_figures(DELAY_SWEEP, rows, tmp_path)
    assert files["png"].stat().st_size > 1000


@pytest.mark.slow  # Dask's 10 s connect timeout
def test_an_unreachable_scheduler_exits_1_with_one_line_and_leaves_no_output_directory(tmp_path, capsys):
    out = tmp_path / "new" / "out"
    assert cli.main(["study", "gain_sweep", "--scheduler", "tcp://127.0.0.1:1", "--out", str(out)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[0] == "connecting to the Dask scheduler at tcp://127.0.0.1:1"
    assert len(err) == 2 and err[1].startswith("drake-sot study: ") and "tcp://127.0.0.1:1" in err[1]
    assert list(tmp_path.iterdir()) == []  # neither out nor its new parent


@pytest.mark.slow  # Dask's 10 s connect timeout
def test_an_unreachable_scheduler_leaves_an_existing_output_directory_as_it_was(tmp_path):
    (tmp_path / "notes.txt").write_text("mine")
    assert cli.main(["study", "gain_sweep", "--scheduler", "tcp://127.0.0.1:1", "--out", str(tmp_path)]) == 1
    assert [p.name for p in tmp_path.iterdir()] == ["notes.txt"]


def test_a_full_disk_costs_the_study_its_figures_with_one_line_and_exit_1(tmp_path, monkeypatch, capsys):
    """The runs are in the table; the figures do not fit: one line names them, the table is
    still listed as written, exit status 1 (no traceback)."""
    table = tmp_path / "gain_sweep_runs.csv"

    def ran(study, out, **kwargs):
        table.write_text("run_id\n")
        return StudyOutcome(table, tmp_path / "gain_sweep_runs.npz", {"0" * 16: {"status": "ok"}})

    def full(study, rows, out):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(out / "gain_sweep.png"))

    monkeypatch.setattr(study_session, "run_study", ran)
    monkeypatch.setitem(study_session.STUDY_FIGURES, "gain_sweep", full)
    assert cli.main(["study", "gain_sweep", "--out", str(tmp_path)]) == 1
    captured = capsys.readouterr()
    assert (
        captured.err == f"could not write: {tmp_path}/gain_sweep.* (No space left on device, errno ENOSPC)\n"
    )
    assert captured.out == f"wrote {table}\n"
