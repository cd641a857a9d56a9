"""Random reachable footsteps for a walk of any length: forward, backward, sideways and turning
steps, with stops, kept near a home point (pure: no Drake).

:class:`RandomStepRule` decides the next footprint from the last planned ones and the time, with
no state of its own: the randomness of a step is seeded by the rule's seed and the footprint it
steps from, so that a walk is reproduced exactly from its seed and a rule can be asked again
about the same step (a Drake output port may be evaluated several times per tick). Each step is
the other foot's move, relative to the stance foot (as :func:`drake_sot.footsteps.relative_steps`):

- ``dx`` in ``[-max_back, max_forward]`` [m] along the stance foot's heading;
- the lateral distance from the stance foot: the stance width plus ``[0, max_out]`` [m] outwards;
- a relative yaw in ``[-max_turn, max_turn]`` [rad].

Far from home (beyond ``home_radius``), the step is drawn towards home instead: it turns the
robot's heading towards the home point, and goes forward once it faces it. During the last
``pause`` seconds of every ``pause_period`` no step is given: the pattern generator brings the
feet side by side and the robot stands. A drawn step that breaks the pattern generator's
:class:`~drake_sot.footsteps.StepLimits` is replaced by the step that puts the foot beside the
stance foot (always reachable for a stance width within the limits).
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.footsteps import Footstep, StepLimits, compose, mean_yaw, wrap_angle


@dataclass(frozen=True)
class RandomStepRule:
    """The next footprint of a random walk (see the module docstring).

    Attributes:
        seed: the walk's seed (an integer >= 0); the same seed gives the same walk.
        width: [m] the stance width (lateral distance of the feet standing side by side).
        limits: the pattern generator's step limits.
        max_forward: [m] the longest step forward (>= 0).
        max_back: [m] the longest step backward (>= 0).
        max_out: [m] the widest step outwards beyond the stance width (>= 0).
        max_turn: [rad] the largest turn of one step (>= 0).
        home: (2,) [m] the point the walk stays near.
        home_radius: [m] beyond it, steps lead back home (> 0).
        pause_period: [s] a stop every so often (> pause).
        pause: [s] how long each stop lasts (>= 0).

    Raises:
        ValueError: a value out of its range, naming it.
    """

    seed: int
    width: float
    limits: StepLimits = StepLimits()
    max_forward: float = 0.2
    max_back: float = 0.12
    max_out: float = 0.08
    max_turn: float = 0.2
    home: tuple[float, float] = (0.0, 0.0)
    home_radius: float = 1.5
    pause_period: float = 20.0
    pause: float = 4.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "seed", validation.positive_int("seed", self.seed, minimum=0))
        validation.bounded("width", self.width, self.limits.min_width, self.limits.max_width, unit="m")
        for name in ("max_forward", "max_back", "max_out", "max_turn", "pause"):
            validation.nonnegative(name, getattr(self, name))
        validation.vector("home", self.home, 2)
        validation.positive("home_radius", self.home_radius, unit="m")
        if not (validation.positive("pause_period", self.pause_period, unit="s") > self.pause):
            raise ValueError(f"pause_period = {self.pause_period} s: must exceed pause = {self.pause} s")

    def next_footprint(
        self, left: Footstep, right: Footstep, last: str | None, time: float
    ) -> Footstep | None:
        """The footprint after ``left`` and ``right`` (the last planned ones; ``last`` the side
        of the last planned step, None before any) at ``time`` [s]; None during a stop."""
        if time % self.pause_period >= self.pause_period - self.pause:
            return None
        side = "right" if last in (None, "left") else "left"
        stance = left if side == "right" else right
        outward = 1.0 if side == "left" else -1.0
        rng = np.random.default_rng([self.seed, *_bits(stance)])
        heading = mean_yaw(left.yaw, right.yaw)
        middle = 0.5 * (left.xy + right.xy)
        away = middle - np.asarray(self.home)
        if math.hypot(*away) > self.home_radius:
            towards = wrap_angle(math.atan2(-away[1], -away[0]) - heading)
            turn = float(np.clip(towards, -self.max_turn, self.max_turn))
            dx = self.max_forward * max(math.cos(towards), 0.0)
        else:
            turn = float(rng.uniform(-self.max_turn, self.max_turn))
            dx = float(rng.uniform(-self.max_back, self.max_forward))
        dy = outward * (self.width + float(rng.uniform(0.0, self.max_out)))
        # the new foot's yaw: the stance foot's turned by at most the turn from the heading
        step = compose(stance, dx, dy, wrap_angle(heading + turn - stance.yaw), side)
        try:
            self.limits.check(stance, step)
        except ValueError:
            return compose(stance, 0.0, outward * self.width, 0.0, side)
        return step


def _bits(step: Footstep) -> list[int]:
    """The footprint as integers (its floats' bit patterns), to seed a generator with it."""
    return [int.from_bytes(struct.pack("<d", value), "little") for value in (step.x, step.y, step.yaw)]
