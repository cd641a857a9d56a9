"""The closing report of a run's self-collision logs (drake_sot.diagrams.collision_log), on
logs written by hand: the least distance with its bodies and time, the pairs of bodies within
d_i at the end (closest first, each once, the rest counted), a margin crossed, no pair at all."""

from __future__ import annotations

import numpy as np

from drake_sot.diagrams.collision_log import collision_report

NAN = np.nan
BODIES = [
    ("hand", "torso"),
    ("hand", "torso"),
    ("foot_l", "foot_r"),
    ("a", "b"),
    ("c", "d"),
    ("e", "f"),
    ("g", "h"),
]


def _arrays(distance, pair, d_s=0.01, d_i=0.05) -> dict[str, np.ndarray]:
    pairs = np.array(
        [(f"{a}_shape{k}", f"{b}_shape{k}", a, b) for k, (a, b) in enumerate(BODIES)],
        dtype=[("shape_a", "U16"), ("shape_b", "U16"), ("body_a", "U16"), ("body_b", "U16")],
    )
    return {
        "time": np.array([0.0, 0.1, 0.2]),
        "collision/taskSelf/distance": np.array(distance, dtype=float),
        "collision/taskSelf/pair": np.array(pair),
        "collision/taskSelf/pairs": pairs,
        "collision/taskSelf/margins": np.array([d_s, d_i]),
    }


def test_the_least_distance_and_the_pairs_of_bodies_at_the_end():
    """The least is 0.02 m at 0.1 s (hand and torso's second shapes); at the end the hand and
    the torso (twice: their least, 0.03 m, counts) and the feet."""
    arrays = _arrays(
        [[0.04, NAN, NAN], [0.02, 0.045, NAN], [0.03, 0.035, 0.04]],
        [[2, -1, -1], [1, 2, -1], [0, 1, 2]],
    )
    assert collision_report(arrays) == [
        "taskSelf: least distance 0.0200 m (hand–torso) at t = 0.100 s, outside the margin d_s = 0.01 m",
        "taskSelf: at the end (t = 0.200 s), closer than d_i = 0.05 m: hand–torso 0.0300 m, "
        "foot_l–foot_r 0.0400 m",
    ]


def test_a_crossed_margin_and_more_pairs_than_listed():
    arrays = _arrays(
        [[NAN] * 7, [NAN] * 7, [0.004, 0.01, 0.02, 0.03, 0.04, 0.045, 0.05]],
        [[-1] * 7, [-1] * 7, [1, 2, 3, 4, 5, 6, 0]],
    )
    least, at_end = collision_report(arrays)
    assert least == (
        "taskSelf: least distance 0.0040 m (hand–torso) at t = 0.200 s, "
        "0.0060 m inside the margin d_s = 0.01 m"
    )
    assert at_end.endswith(
        "hand–torso 0.0040 m, foot_l–foot_r 0.0100 m, a–b 0.0200 m, c–d 0.0300 m, e–f 0.0400 m "
        "and 1 more pair of bodies"
    )


def test_no_pair_within_the_activation_distance():
    assert collision_report(_arrays([[NAN] * 2] * 3, [[-1] * 2] * 3)) == [
        "taskSelf: no pair of shapes came closer than d_i = 0.05 m"
    ]
    arrays = _arrays([[0.04, NAN], [NAN, NAN], [NAN, NAN]], [[2, -1], [-1, -1], [-1, -1]])
    assert (
        collision_report(arrays)[1] == "taskSelf: at the end (t = 0.200 s), no pair closer than d_i = 0.05 m"
    )


def test_a_run_without_the_task_reports_nothing():
    assert collision_report({"time": np.array([0.0, 0.1])}) == []
