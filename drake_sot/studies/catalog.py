"""The studies of the ``drake-sot study`` command, as data (their targets are those of
:mod:`drake_sot.diagrams.study_runs`)."""

from __future__ import annotations

import numpy as np

from drake_sot.studies.description import Bisection, Grid, Study

#: The α values of both axes of ``alpha_sweep``: {0, 0.2, ..., 1}.
ALPHA_GRID = tuple(float(a) for a in np.round(np.linspace(0.0, 1.0, 6), 3))

ALPHA_SWEEP = Study(
    name="alpha_sweep",
    description="steady head and left-hand errors over a 6x6 grid of constant priorities "
    "(Liu, Lober, Padois 2016, fig. 11)",
    scenario="priority_switching",
    runs=Grid({"alpha_lh_head": ALPHA_GRID, "alpha_head_lh": ALPHA_GRID}),
    duration=4.0,  # [s]: the errors settle in 3 s; the steady ones are averaged over the last second
    metrics=("steady_error_head", "steady_error_lh", "max_final_error_m", "max_final_error_rad"),
    fixed={"robot": "embedded"},
)

#: When ``push_recovery`` pushes [s]: a quarter of the embedded humanoid's 0.8 s step apart,
#: from the fourth step's start on (the steps begin at 0.5 s), over one step.
PUSH_TIMES = (2.1, 2.3, 2.5, 2.7)
#: Which way it pushes [deg from the x axis (forward) towards y (left)].
PUSH_DIRECTIONS = (0.0, 90.0, 180.0, 270.0)

PUSH_RECOVERY = Study(
    name="push_recovery",
    description="the largest 0.1 s pelvis push the walk survives, by bisection, over push time "
    "(gait phase) x direction, with and without the stabilizer",
    scenario="walk",
    runs=Bisection(
        Grid({"stabilizer": (True, False), "push_time": PUSH_TIMES, "push_direction": PUSH_DIRECTIONS}),
        "push_force",
        low=0.0,
        high=800.0,
        iterations=5,  # to 25 N
    ),
    duration=5.0,  # [s]: at least 2.3 s after the last push, time enough to fall
    metrics=("survived", "fall_time", "min_pelvis_height", "max_final_error_m", "max_final_error_rad"),
    fixed={"robot": "embedded", "push_duration": 0.1},
)

GAIN_SWEEP = Study(
    name="gain_sweep",
    description="reach's right hand over its task's gain: how long it takes to settle within 1 cm "
    "and the error left at 3 s",
    scenario="reach",
    runs=Grid({"rh_gain": (0.5, 1.0, 2.5, 5.0, 10.0, 20.0)}),
    duration=3.0,  # [s]: the target moves at 1 s
    metrics=("survived", "rh_settle_time", "final_error/taskRH", "max_final_error_m", "max_final_error_rad"),
    fixed={"robot": "embedded"},
)

#: The one-way delays of ``delay_sweep`` [s]: 0 to 250 ms (the Munich-Tsukuba link of Evrard et al.
#: 2009 is 140 ms); with the largest jitter the worst delay stays within the link's 300 ms.
DELAYS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25)

DELAY_SWEEP = Study(
    name="delay_sweep",
    description="the tele-cooperation standing (Evrard et al. 2009): hand tracking and force "
    "transparency over the link's one-way delay, with and without jitter and packet loss",
    scenario="telecooperation_standing",
    runs=Grid({"jitter": (0.0, 0.04), "loss": (0.0, 0.3), "delay": DELAYS}),
    duration=4.0,  # [s]: the leader lifts the board from 1 s to 2 s, sets it back by 3 s
    metrics=(
        "tracking_error_rms",
        "tracking_error_max",
        "force_error_rms",
        "force_ratio",
        "survived",
        "fall_time",
        "min_pelvis_height",
    ),
    fixed={"leader": "operator", "admittance": "plain"},
)

#: The studies, by name.
STUDIES: dict[str, Study] = {s.name: s for s in (ALPHA_SWEEP, PUSH_RECOVERY, GAIN_SWEEP, DELAY_SWEEP)}
