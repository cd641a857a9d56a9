"""Disturbances: pushes on the robot, a constant force on a logical frame for a while.

An :class:`ExternalPush` names a logical frame of the robot (``pelvis``, ``torso``,
``right_hand``…, see :data:`drake_sot.models.humanoid.FRAMES`); the builders
(``pushes=`` of :class:`~drake_sot.diagrams.tasks.HumanoidTaskBuilder`) apply it at that
frame's origin through a :class:`~drake_sot.systems.partner.Partner` whose script is one
:class:`~drake_sot.systems.partner.ConstantForce` per push. :func:`pushes_record` is how a
run's npz stores them.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from drake_sot import validation

#: The npz record of the pushes (one row per push): start [s], logical frame, force (3,)
#: [N] in the world frame, duration [s].
PUSH_DTYPE = np.dtype([("time", "f8"), ("body", "U32"), ("force", "f8", (3,)), ("duration", "f8")])


@dataclass(frozen=True)
class ExternalPush:
    """A constant force ``force`` (3,) [N], world frame, on the origin of the robot's logical
    frame ``body``, from ``time`` [s] for ``duration`` [s].

    Raises:
        ValueError: naming the field: a ``time`` that is not finite and >= 0, a ``body``
            that is not a non-empty string, a non-finite ``force`` component, a
            ``duration`` that is not finite and > 0.
    """

    time: float
    body: str
    force: tuple[float, float, float]
    duration: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "time", validation.nonnegative("time", self.time, unit="s"))
        object.__setattr__(self, "body", validation.nonempty_string("body", self.body))
        object.__setattr__(self, "force", tuple(float(f) for f in validation.vector("force", self.force, 3)))
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


def check_pushes(pushes: Sequence[ExternalPush], frames: Mapping[str, str]) -> tuple[ExternalPush, ...]:
    """``pushes`` as a tuple, each on one of ``frames`` (logical names) and no two on the same
    frame at once.

    Raises:
        ValueError: a push that is not a :class:`ExternalPush`, an unknown frame (listing the known
            ones), or two pushes on one frame that overlap in time (naming both).
    """
    pushes = tuple(pushes)
    for push in pushes:
        if not isinstance(push, ExternalPush):
            raise ValueError(f"pushes: {push!r} is not an ExternalPush")
        if push.body not in frames:
            raise ValueError(f"push body = {push.body!r}: unknown frame; known: {', '.join(frames)}")
    for i, a in enumerate(pushes):
        for b in pushes[i + 1 :]:
            if a.body == b.body and a.time < b.end and b.time < a.end:
                raise ValueError(
                    f"pushes on {a.body!r} overlap: {a.label} at t = {a.time:g} s and "
                    f"{b.label} at t = {b.time:g} s"
                )
    return pushes


def pushes_record(pushes: Sequence[ExternalPush]) -> np.ndarray:
    """The pushes as a structured array of :data:`PUSH_DTYPE` (no pickle needed to load it)."""
    return np.array([(p.time, p.body, p.force, p.duration) for p in pushes], dtype=PUSH_DTYPE)
