"""The table a resumed study reads back, damaged: cut short anywhere, garbage bytes anywhere, a
row with a field missing. Either the file is refused with one line naming it, or the rows that
are not whole are skipped and said, and every row read is one that was written: never a
traceback, never a run silently lost."""

from __future__ import annotations

import csv
import io
import math
import tempfile
from datetime import timedelta
from pathlib import Path

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from test_studies import DECLARED, counting, grid_study, run_in_threads

from drake_sot.studies.runner import read_table, table_columns
from drake_sot.validation import is_number

STUDY = grid_study()
COLUMNS = table_columns(STUDY)
FUZZ = settings(deadline=None, derandomize=True, suppress_health_check=[HealthCheck.function_scoped_fixture])


def _row(k: int) -> list[str]:
    """A whole row of the table, as run_study writes it (the error cell empty, as for an ok run)."""
    cells = {"run_id": f"{k:016x}", "force": f"{100.0 * k}", "phase": "0.5", "survived": str(k % 2 == 0)}
    cells |= {"margin": repr(37.3 - k), "seed": str(k), "duration": "1.0", "worker": "tcp://127.0.0.1:1"}
    cells |= {"wall_time": "0.25", "drake_sot_version": "0.1", "drake_version": "1.40"}
    cells |= {"status": "ok", "error": ""}
    return [cells[c] for c in COLUMNS]


def _table(rows: int) -> bytes:
    """The header and the first ``rows`` rows, as csv writes them (lines ending in CR LF)."""
    text = io.StringIO(newline="")
    writer = csv.writer(text)
    writer.writerow(COLUMNS)
    writer.writerows(_row(k) for k in range(rows))
    return text.getvalue().encode()


WRITTEN = {_row(k)[0]: dict(zip(COLUMNS, _row(k), strict=True)) for k in range(6)}


def _said_skipped(path, count: int) -> list[str]:
    return [f"{path}: {count} rows not whole (a line cut short?) skipped: their runs are run again"]


def _read(path) -> tuple[dict | None, list[str], str | None]:
    """(rows, what was said, the refusal) of reading ``path`` back."""
    said: list[str] = []
    try:
        return read_table(path, STUDY, said.append), said, None
    except ValueError as exc:
        return None, said, str(exc)


def _as_written(rows: dict) -> None:
    """Every row read is a row written, its cells read as written."""
    for run, row in rows.items():
        written = WRITTEN[run]
        assert list(row) == list(COLUMNS) and row["status"] == "ok" and row["error"] == ""
        assert row["force"] == float(written["force"]) and row["margin"] == float(written["margin"])
        assert row["survived"] is (written["survived"] == "True")


@FUZZ
@given(cut=st.integers(min_value=len(_table(0)), max_value=len(_table(6))))
def test_a_table_cut_short_anywhere_loses_only_its_cut_row_and_says_so(tmp_path, cut):
    path = tmp_path / "fake_runs.csv"
    path.write_bytes(_table(6)[:cut])
    rows, said, refusal = _read(path)
    assert refusal is None
    whole = sum(len(_table(k + 1)) - 2 <= cut for k in range(6))  # rows whose cells are all there
    assert set(rows) == {_row(k)[0] for k in range(whole)}
    _as_written(rows)
    partial = whole < 6 and cut > len(_table(whole))  # a part of the next row
    assert said == (_said_skipped(path, 1) if partial else [])


@FUZZ
@given(at=st.integers(min_value=0, max_value=len(_table(6))), garbage=st.binary(min_size=1, max_size=40))
def test_garbage_bytes_anywhere_are_refused_naming_the_file_or_a_run_they_hide_is_said(tmp_path, at, garbage):
    path = tmp_path / "fake_runs.csv"
    table = _table(6)
    path.write_bytes(table[:at] + garbage + table[at:])
    rows, said, refusal = _read(path)
    if refusal is not None:
        assert refusal.startswith(f"{path}: ") and "\n" not in refusal, refusal
        return
    assert all(list(row) == list(COLUMNS) and row["status"] in ("ok", "failed") for row in rows.values())
    if set(WRITTEN) - set(rows):
        assert len(said) == 1 and said[0].startswith(f"{path}: ") and "\n" not in said[0], said


@FUZZ
@given(row=st.integers(min_value=0, max_value=5), drop=st.integers(min_value=0, max_value=len(COLUMNS) - 1))
def test_a_row_with_a_field_missing_is_skipped_and_said(tmp_path, row, drop):
    lines = _table(6).decode().split("\r\n")
    cells = next(csv.reader([lines[1 + row]]))
    del cells[drop]
    text = io.StringIO(newline="")
    csv.writer(text).writerow(cells)
    lines[1 + row] = text.getvalue().removesuffix("\r\n")
    path = tmp_path / "fake_runs.csv"
    path.write_text("\r\n".join(lines), newline="")
    rows, said, refusal = _read(path)
    assert refusal is None
    assert set(rows) == set(WRITTEN) - {_row(row)[0]}
    _as_written(rows)
    assert said == _said_skipped(path, 1)


def test_a_table_of_other_bytes_than_text_is_refused_naming_the_file(tmp_path):
    path = tmp_path / "fake_runs.csv"
    path.write_bytes(_table(2) + b"\xff\xfe\x00garbage\r\n")
    rows, _, refusal = _read(path)
    assert rows is None and refusal.startswith(f"{path}: not a study table (")


def test_a_resumed_study_runs_the_row_cut_short_again_on_a_line_of_its_own(tmp_path):
    """The table's last row cut in its middle (a crash while writing it): the study given the
    directory again says so, runs that run again, and its new row does not join the cut one."""
    first = run_in_threads(grid_study(), tmp_path)
    data = first.table.read_bytes()
    last_line = data.removesuffix(b"\r\n").rsplit(b"\r\n", 1)[1]
    first.table.write_bytes(data[: len(data) - 2 - len(last_line) // 2])  # half of the last row
    said: list[str] = []
    again = run_in_threads(grid_study(), tmp_path, measure=counting, say=said.append)
    assert again.ran == 1 and again.skipped == 5
    assert _said_skipped(first.table, 1)[0] in said, said
    rows, said, refusal = _read(first.table)
    assert refusal is None and len(rows) == 6 and {r["status"] for r in rows.values()} == {"ok"}
    assert said == _said_skipped(first.table, 1)  # the half row, still there: its run is in the new one
    assert all(math.isfinite(r["margin"]) for r in rows.values())


def test_a_blank_line_is_no_row_and_nothing_is_said(tmp_path):
    """What a row appended after a line cut at its CR leaves: ``CR CR LF``, a blank line."""
    path = tmp_path / "fake_runs.csv"
    path.write_bytes(_table(3).removesuffix(b"\n") + b"\r\n" + _table(6)[len(_table(3)) :])
    rows, said, refusal = _read(path)
    assert refusal is None and set(rows) == set(WRITTEN) and said == []


#: What an edited cell may hold: numbers of any size and form, text (lone surrogates and the
#: characters CSV quotes included), empty.
CELLS = st.one_of(
    st.sampled_from(
        ["", "nan", "inf", "-inf", "1e400", "-1e400", "9" * 5000, "0.50", "True", "False", "true"]
    ),
    st.integers(min_value=-(10**400), max_value=10**400).map(str),
    st.floats(allow_nan=True, allow_infinity=True).map(repr),
    st.text(st.characters(codec=None, exclude_categories=()), max_size=30),
)
NUMBER_COLUMNS = (*STUDY.parameter_names(), *STUDY.metrics, "seed", "duration", "wall_time")


@settings(max_examples=300, deadline=timedelta(seconds=5), derandomize=True)
@given(row=st.integers(min_value=0, max_value=5), column=st.sampled_from(COLUMNS), cell=CELLS)
def test_an_edited_cell_is_read_as_written_or_refused_in_one_line_naming_the_file(row, column, cell):
    """Any cell of a whole table replaced by any text (written as UTF-8, a lone surrogate as the
    bytes it would be): read back, or refused (ValueError, one line naming the file, its line and
    column); never another exception. What is read is what a run writes: its numbers as a float's
    repr or an int's str, an ok run's metrics a bool or a number, its parameters in their bounds."""
    lines = _table(6).decode().split("\r\n")
    cells = next(csv.reader([lines[1 + row]]))
    cells[COLUMNS.index(column)] = cell
    text = io.StringIO(newline="")
    csv.writer(text).writerow(cells)
    lines[1 + row] = text.getvalue().removesuffix("\r\n")
    with tempfile.TemporaryDirectory() as directory:
        path = Path(directory) / "fake_runs.csv"
        path.write_bytes("\r\n".join(lines).encode("utf-8", "surrogatepass"))
        try:
            rows = read_table(path, STUDY, declared=DECLARED)
        except ValueError as exc:
            message = str(exc)
            assert message.startswith(f"{path}: ") and "\n" not in message, message
            return
    for read in rows.values():
        for name in NUMBER_COLUMNS:
            value = read[name]
            if isinstance(value, float) and not isinstance(value, bool):
                assert math.isnan(value) or math.isinf(value) or abs(value) < 1.8e308
        if read["status"] == "ok":
            assert all(isinstance(read[m], bool | float) for m in STUDY.metrics), read
            assert all(type(read[c]) is float for c in ("seed", "duration", "wall_time")), read
        assert 0.0 <= read["force"] <= 1000.0 and 0.0 <= read["phase"] <= 1.0, read
    edited = rows.get(cells[0]) if column != "run_id" else None
    if edited is not None and column in NUMBER_COLUMNS and is_number(cell):
        value = edited[column]
        assert cell == repr(value) or (value.is_integer() and cell == str(int(value))), (cell, value)


def test_a_table_that_is_a_directory_or_a_link_to_nothing_is_refused_naming_it(tmp_path):
    (tmp_path / "fake_runs.csv").mkdir()
    assert _read(tmp_path / "fake_runs.csv")[2] == (
        f"{tmp_path / 'fake_runs.csv'}: not a regular file (a directory): give another output directory"
    )
    (tmp_path / "other_runs.csv").symlink_to(tmp_path / "nowhere")
    assert _read(tmp_path / "other_runs.csv")[2] == (
        f"{tmp_path / 'other_runs.csv'}: a link to nothing: give another output directory"
    )
