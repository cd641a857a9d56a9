"""Where each foot landed in a walk, for the walking tests of every robot."""

from __future__ import annotations

import math

import numpy as np

SETTLE = 10  # control ticks after touch-down (50 ms) at which a landing is measured


def landing_errors(arrays: dict[str, np.ndarray], soles: dict, steps: list) -> list[tuple[str, float, float]]:
    """Per landing, in order: (side, distance [m] from its footprint, yaw error [deg]).

    A landing ends a single-support phase (the generator's ``phase`` log switches back to
    double support); the measured sole (``soles[side]``, (T, 3) x, y, yaw) is read ``SETTLE``
    ticks after it. Asserts as many landings as ``steps``."""
    phase = arrays["phase"][:, 0]
    landings = [k for k in range(1, len(phase)) if phase[k - 1] != 0 and phase[k] == 0]
    assert len(landings) == len(steps), f"{len(landings)} landings for {len(steps)} steps"
    errors = []
    for k, step in zip(landings, steps, strict=True):
        x, y, yaw = soles[step.side][k + SETTLE]
        errors.append(
            (
                step.side,
                math.hypot(x - step.x, y - step.y),
                abs(math.degrees(math.remainder(yaw - step.yaw, 2 * math.pi))),
            )
        )
    return errors
