"""Pushes as values: checked fields, checked against the robot's frames, stored in an npz."""

import math

import numpy as np
import pytest

from drake_sot.diagrams.pushes import PUSH_DTYPE, ExternalPush, check_pushes, pushes_record
from drake_sot.errors import UnknownNameError
from drake_sot.models.humanoid import FRAMES


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((math.nan, "pelvis", (0, 1, 0), 0.1), "time = nan s: must be finite and >= 0"),
        ((-0.5, "pelvis", (0, 1, 0), 0.1), "time = -0.5 s: must be finite and >= 0"),
        ((0.5, "", (0, 1, 0), 0.1), "body = '': must be a non-empty string"),
        ((0.5, None, (0, 1, 0), 0.1), "body = None: must be a non-empty string"),
        ((0.5, "pelvis", (0, math.inf, 0), 0.1), r"force = .*contains NaN or Inf \(entry \[1\]\)"),
        ((0.5, "pelvis", (0, 1), 0.1), r"force must have shape \(3,\)"),
        ((0.5, "pelvis", (0, 1, 0), 0.0), "duration = 0.0 s: must be finite and > 0"),
        ((0.5, "pelvis", (0, 1, 0), math.nan), "duration = nan s: must be finite and > 0"),
    ],
)
def test_a_push_refuses_bad_fields(args, message):
    with pytest.raises(ValueError, match=message):
        ExternalPush(*args)


def test_a_push_on_an_unknown_frame_is_refused_with_the_known_ones():
    with pytest.raises(
        ValueError, match=f"^push body: unknown frame 'elbow'; known: {', '.join(sorted(FRAMES))}$"
    ):
        check_pushes([ExternalPush(0.5, "elbow", (0, 1, 0), 0.1)], FRAMES)
    with pytest.raises(UnknownNameError) as caught:
        check_pushes([ExternalPush(0.5, "right_hnd", (0, 1, 0), 0.1)], FRAMES)
    assert (caught.value.kind, caught.value.name, caught.value.known) == (
        "frame",
        "right_hnd",
        tuple(sorted(FRAMES)),
    )
    assert "(did you mean 'right_hand'?)" in str(caught.value)


def test_pushes_on_one_frame_may_follow_but_not_overlap():
    first = ExternalPush(0.5, "pelvis", (0, 100, 0), 0.1)
    assert check_pushes([first, ExternalPush(0.6, "pelvis", (0, -100, 0), 0.1)], FRAMES)  # back to back
    assert check_pushes([first, ExternalPush(0.55, "torso", (0, -100, 0), 0.1)], FRAMES)  # another frame
    with pytest.raises(ValueError, match="pushes on 'pelvis' overlap"):
        check_pushes([first, ExternalPush(0.55, "pelvis", (0, -100, 0), 0.1)], FRAMES)


def test_the_npz_record_loads_without_pickle(tmp_path):
    pushes = [
        ExternalPush(0.5, "pelvis", (0, 3000, 0), 0.1),
        ExternalPush(2.0, "right_hand", (-20, 0, 5), 0.25),
    ]
    np.savez(tmp_path / "p.npz", pushes=pushes_record(pushes), empty=pushes_record([]))
    logs = np.load(tmp_path / "p.npz")  # allow_pickle=False
    record = logs["pushes"]
    assert record.dtype == PUSH_DTYPE and logs["empty"].shape == (0,)
    for row, push in zip(record, pushes, strict=True):
        assert row["time"] == push.time and row["body"] == push.body and row["duration"] == push.duration
        np.testing.assert_array_equal(row["force"], push.force)


def test_label():
    assert (
        ExternalPush(0.5, "pelvis", (0, 300, -400), 0.1).label == "push pelvis 500 N (0, 300, -400) for 0.1 s"
    )
