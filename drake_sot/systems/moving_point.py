"""``MovingPoint``: a point of the world moving along a given path, p(t) and ṗ(t)."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.systems.framework import Context

from drake_sot.systems.leaf import SotLeafSystem

#: A path: time [s] → (position (3,) [m], velocity (3,) [m/s]), both in world.
Path = Callable[[float], tuple[np.ndarray, np.ndarray]]


class MovingPoint(SotLeafSystem):
    """A point that moves along ``path`` (an object the robot looks at or reaches for).

    The outputs depend on time only; they feed a visual point feature (``point``,
    ``point_velocity``) or a pose feature's desired value (``pose``, ``spatial_velocity``:
    a frame at the point with a fixed orientation, so that a hand follows it).

    Output ports:
        position: p(t) (3,) [m], world.
        velocity: ṗ(t) (3,) [m/s], world.
        pose: abstract ``RigidTransform``, the point with the orientation ``orientation``.
        spatial_velocity: ``[ṗ; 0]`` (6,) [m/s, rad/s], the ``velocity_des`` of
            :class:`~drake_sot.systems.features.FeaturePoint6d`.

    Args:
        path: t → (p, ṗ), evaluated when an output is.
        orientation: the orientation of ``pose`` (world frame).
        name: the system's name.

    Raises:
        RuntimeError: when an output is evaluated and the path gives anything else than
            two finite 3-vectors, naming the system and the time.
    """

    def __init__(
        self, path: Path, *, orientation: RotationMatrix | None = None, name: str = "moving_point"
    ) -> None:
        super().__init__()
        self.set_name(name)
        self._path = path
        self._orientation = RotationMatrix() if orientation is None else orientation
        time = {self.time_ticket()}
        self.DeclareVectorOutputPort(
            "position", 3, lambda c, out: out.SetFromVector(self._sample(c)[0]), prerequisites_of_calc=time
        )
        self.DeclareVectorOutputPort(
            "velocity", 3, lambda c, out: out.SetFromVector(self._sample(c)[1]), prerequisites_of_calc=time
        )
        self.DeclareAbstractOutputPort(
            "pose",
            lambda: AbstractValue.Make(RigidTransform()),
            lambda c, out: out.set_value(RigidTransform(self._orientation, self._sample(c)[0])),
            prerequisites_of_calc=time,
        )
        self.DeclareVectorOutputPort(
            "spatial_velocity",
            6,
            lambda c, out: out.SetFromVector(np.concatenate((self._sample(c)[1], np.zeros(3)))),
            prerequisites_of_calc=time,
        )

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """``(p, ṗ)`` at time ``t`` [s], checked (as the outputs are)."""
        p, v = (np.asarray(x, dtype=float) for x in self._path(t))
        if p.shape != (3,) or v.shape != (3,) or not (np.isfinite(p).all() and np.isfinite(v).all()):
            raise RuntimeError(
                f"{self.get_name()!r} at t = {t:.4f} s: the path gave position {p} and velocity {v}; "
                "expected two finite 3-vectors"
            )
        return p, v

    def _sample(self, context: Context) -> tuple[np.ndarray, np.ndarray]:
        return self.sample(context.get_time())
