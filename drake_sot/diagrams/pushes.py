"""Disturbances: pushes on the robot, a constant force on a logical frame for a while.

An :class:`ExternalPush` names a logical frame of the robot (``pelvis``, ``waist``,
``right_hand``…, one of :data:`drake_sot.robots.description.LOGICAL_FRAMES`); the builders
(``pushes=`` of :class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder`) apply it at that
frame's origin through a :class:`~drake_sot.systems.partner.Partner` whose script is one
:class:`~drake_sot.systems.partner.ConstantForce` per push. :func:`pushes_record` is how a
run's npz stores them.
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence
from dataclasses import dataclass

import numpy as np

from drake_sot import validation
from drake_sot.diagrams.run import MAX_DURATION
from drake_sot.errors import UnknownNameError

#: The largest push [N] (norm of the force): 10 kN, seventeen times the embedded humanoid's
#: weight (58 kg) and eleven times TALOS's (93 kg). Held for the shortest push the scenarios
#: use (0.1 s) it is an impulse of 1000 N s, which throws any of them metres away: a larger
#: force is a typo, and one near the float range (1e300) ends the contact solver's run.
MAX_PUSH_FORCE = 1e4

#: The npz record of the pushes (one row per push): start [s], logical frame, force (3,)
#: [N] in the world frame, duration [s].
PUSH_DTYPE = np.dtype([("time", "f8"), ("body", "U32"), ("force", "f8", (3,)), ("duration", "f8")])


@dataclass(frozen=True)
class ExternalPush:
    """A constant force ``force`` (3,) [N], world frame, on the origin of the robot's logical
    frame ``body``, from ``time`` [s] for ``duration`` [s].

    Raises:
        ValueError: naming the field: a ``time`` that is not finite and >= 0 or after the
            longest run (:data:`~drake_sot.diagrams.run.MAX_DURATION`), a ``body``
            that is not a non-empty string, a non-finite ``force`` component or a force of
            more than :data:`MAX_PUSH_FORCE`, a ``duration`` that is not finite and > 0.
    """

    time: float
    body: str
    force: tuple[float, float, float]
    duration: float

    def __post_init__(self) -> None:
        time = validation.nonnegative("time", self.time, unit="s")
        object.__setattr__(self, "time", validation.bounded("time", time, 0.0, MAX_DURATION, unit="s"))
        object.__setattr__(self, "body", validation.nonempty_string("body", self.body))
        object.__setattr__(self, "force", tuple(float(f) for f in validation.vector("force", self.force, 3)))
        validation.bounded("|force|", math.hypot(*self.force), 0.0, MAX_PUSH_FORCE, unit="N")
        object.__setattr__(self, "duration", validation.positive("duration", self.duration, unit="s"))

    @property
    def end(self) -> float:
        """When the push stops [s]."""
        return self.time + self.duration

    @property
    def label(self) -> str:
        """A short description, e.g. ``push pelvis 300 N (0, 300, 0) for 0.1 s``."""
        fx, fy, fz = self.force
        magnitude = math.sqrt(fx * fx + fy * fy + fz * fz)
        return f"push {self.body} {magnitude:.0f} N ({fx:g}, {fy:g}, {fz:g}) for {self.duration:g} s"


def check_pushes(pushes: Sequence[ExternalPush], frames: Collection[str]) -> tuple[ExternalPush, ...]:
    """``pushes`` as a tuple, each on one of ``frames`` (logical names, e.g.
    :data:`~drake_sot.robots.description.LOGICAL_FRAMES` or a robot's ``info.frames``) and no
    two on the same frame at once.

    Raises:
        ValueError: a push that is not a :class:`ExternalPush`, an unknown frame
            (:class:`~drake_sot.errors.UnknownNameError`, listing the known ones), or two pushes
            on one frame that overlap in time (naming both).
    """
    pushes = tuple(pushes)
    for push in pushes:
        if not isinstance(push, ExternalPush):
            raise ValueError(f"pushes: {push!r} is not an ExternalPush")
        if push.body not in frames:
            raise UnknownNameError("frame", push.body, frames, where="push body")
    for i, a in enumerate(pushes):
        for b in pushes[i + 1 :]:
            if a.body == b.body and a.time < b.end and b.time < a.end:
                raise ValueError(
                    f"pushes on {a.body!r} overlap: {a.label} at t = {a.time:g} s and "
                    f"{b.label} at t = {b.time:g} s"
                )
    return pushes


def check_push_times(pushes: Sequence[ExternalPush], duration: float) -> None:
    """Refuse a push that starts at or after ``duration`` [s], the end of the run: it would
    never be applied.

    Raises:
        ValueError: naming the push, its start and the run's duration.
    """
    for push in pushes:
        if not (push.time < duration):
            raise ValueError(
                f"{push.label} at t = {push.time:g} s starts after the run's end "
                f"(duration = {duration:g} s): it would never be applied"
            )


def pushes_record(pushes: Sequence[ExternalPush]) -> np.ndarray:
    """The pushes as a structured array of :data:`PUSH_DTYPE` (no pickle needed to load it)."""
    return np.array([(p.time, p.body, p.force, p.duration) for p in pushes], dtype=PUSH_DTYPE)
