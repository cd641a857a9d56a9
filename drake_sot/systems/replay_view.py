"""What a replay shows besides the robot: the forces as arrows (:class:`ForceArrows`, with
:class:`SoleForces` for the contact forces at the soles), the pairs of collision shapes the
self-collision avoidance holds apart as lines between their closest points (:class:`PairLines`)
and a camera that follows the robot (:class:`FollowCamera`).

All draw in Meshcat at a publish period and pass the publish's time to Meshcat, so that while
Meshcat records (``MeshcatVisualizer.StartRecording``) every draw is also a frame of the
recording: the arrows and the camera move in the replay as they do in the live view. The time
passed is the publish's plus half a period (:func:`recording_time`): Meshcat's frame is
``floor(time × frames per second)``, and a publish time ``k / 30`` s computed in floating point
falls a hair short of frame ``k`` about once in twenty (8.2 s is frame 245 at 30 frames per
second), where it would overwrite the previous frame and leave its own empty.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from pydrake.common.value import AbstractValue
from pydrake.geometry import Cylinder, Meshcat, MeshcatCone, Rgba
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import BasicVector, Context

from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import nonempty_string, positive, positive_int

#: The Meshcat path of the viewer's camera: :class:`FollowCamera` moves it.
CAMERA_PATH = "/Cameras/default"

#: [m] where :class:`FollowCamera` puts the camera, from the followed body's (x, y) on the
#: ground: in front of the robot (+x, where it walks), to its right, above its waist.
CAMERA_OFFSET = (2.0, -2.2, 1.2)

#: [m] the height above the ground :class:`FollowCamera`'s camera looks at.
CAMERA_TARGET_HEIGHT = 0.6

#: The Meshcat path under which :class:`ForceArrows` draws (``/forces/<group>/<i>``).
ARROWS_PATH = "/forces"

#: [m] an arrow shorter than this is hidden (no force, or a NaN one).
SHORTEST_ARROW = 1e-3

#: The Meshcat path under which :class:`PairLines` draws (``/self_collision/<task>/<row>``).
PAIRS_PATH = "/self_collision"

#: The colours of :class:`PairLines`: a pair at the activation distance ``d_i`` is drawn in the
#: first, one at the safety margin ``d_s`` (or closer) in the last.
FAR_COLOUR = Rgba(0.1, 0.75, 0.2, 1.0)
NEAR_COLOUR = Rgba(0.9, 0.1, 0.1, 1.0)

#: The number of colours from :data:`FAR_COLOUR` to :data:`NEAR_COLOUR` a pair's line takes:
#: Meshcat's recordings animate what is visible, not colours, so each line is one object per
#: colour, all but one hidden.
PAIR_COLOURS = 5


def recording_time(time: float, period: float) -> float:
    """[s] the time to record a draw at ``time`` [s] under, for a drawer of ``period`` [s]: the
    middle of its frame (see the module's docstring)."""
    return time + period / 2


@dataclass(frozen=True)
class Arrow:
    """One arrow of an :class:`ArrowGroup`: the force (3,) [N], world frame, found at
    components ``offset`` to ``offset + 3`` of the group's input, drawn from the point
    ``point`` (3,) [m] of the plant's body ``body`` (in the body's frame)."""

    body: str
    point: tuple[float, float, float]
    offset: int


@dataclass(frozen=True)
class ArrowGroup:
    """The arrows drawn from one force input of :class:`ForceArrows`, alike in colour and scale.

    Attributes:
        name: the input port's name, and the group's Meshcat path (``/forces/<name>/<i>``).
        label: what the replay's legend says of them (e.g. ``"partner's pull on the hands"``).
        rgba: their colour.
        newtons_per_metre: [N/m] an arrow of force ``f`` is ``|f| / newtons_per_metre`` long.
        size: the size of the input (3 per arrow, or more: a wrench's force is its last 3).
        arrows: the arrows, each reading its force from the input at its ``offset``.
    """

    name: str
    label: str
    rgba: Rgba
    newtons_per_metre: float
    size: int
    arrows: tuple[Arrow, ...]


class SoleForces(SotLeafSystem):
    """The contact force on each of some bodies of the plant (the soles): the sum of the forces
    of the point contacts that body takes part in (the plant's contact model is point contact).

    Input ports:
        contact_results: abstract ``ContactResults`` (the plant's ``contact_results``).
    Output ports:
        forces: (3·k,) [N] the contact force on each body, world frame, in the order of
            ``bodies`` (zero for a body in no contact).

    Args:
        plant: the simulated (finalized) plant.
        bodies: the bodies' names.

    Raises:
        RuntimeError: a body the plant does not have (Drake's message names it).
    """

    def __init__(self, plant: MultibodyPlant, bodies: Sequence[str]) -> None:
        super().__init__()
        self._index = {plant.GetBodyByName(name).index(): k for k, name in enumerate(bodies)}
        self._results = self.DeclareAbstractInputPort(
            "contact_results", plant.get_contact_results_output_port().Allocate()
        )
        self.DeclareVectorOutputPort("forces", 3 * len(bodies), self._forces)

    def _forces(self, context: Context, output: BasicVector) -> None:
        results = self._results.Eval(context)
        forces = np.zeros((len(self._index), 3))
        for i in range(results.num_point_pair_contacts()):
            info = results.point_pair_contact_info(i)
            f = info.contact_force()  # on body B, world frame
            a, b = self._index.get(info.bodyA_index()), self._index.get(info.bodyB_index())
            if a is not None:
                forces[a] -= f
            if b is not None:
                forces[b] += f
        output.SetFromVector(forces.ravel())


class ForceArrows(SotLeafSystem):
    """Forces drawn as arrows in Meshcat (and in its recording), moved at ``period``.

    Each arrow is a shaft and a head (``/forces/<group>/<i>/shaft`` and ``.../head``) whose tip
    is ``|f| / newtons_per_metre`` from the point the force acts on, along the force: the
    transform of ``/forces/<group>/<i>`` puts its origin on the point and its z axis along the
    force, the ``scale`` of the shaft and the position of the head give its length. An arrow
    shorter than :data:`SHORTEST_ARROW` (no force, or a NaN) is hidden.

    Input ports:
        body_poses: abstract ``list[RigidTransform]`` (the plant's ``body_poses``).
        <group.name>: (group.size,) [N] for each group, world frame (see :class:`Arrow`).

    Args:
        meshcat: where to draw.
        plant: the simulated (finalized) plant.
        groups: the arrows, by group.
        period: [s] how often they are drawn, finite and > 0 (1/30 s: the visualizer's rate).
        radius: [m] the shaft's radius, finite and > 0 (the head is 3 times as wide and
            10 times as long).

    Attributes:
        groups: the arrow groups drawn (for a legend).

    Raises:
        ValueError: two groups of one name, an empty name, a ``newtons_per_metre``, ``period``
            or ``radius`` that is not finite and > 0, an arrow whose force lies outside its
            group's input (each named).
        RuntimeError: an arrow on a body the plant does not have (Drake's message names it).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        plant: MultibodyPlant,
        groups: Sequence[ArrowGroup],
        *,
        period: float = 1 / 30,
        radius: float = 0.008,
    ) -> None:
        super().__init__()
        self.set_name("force_arrows")
        self._meshcat = meshcat
        self.groups = tuple(groups)
        radius = positive("radius", radius, unit="m")
        self._head = 10 * radius
        self._period = positive("period", period, unit="s")
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._inputs = []
        self._arrows: list[tuple[str, int, np.ndarray, float]] = []  # (path, body index, point, N/m)
        names = [nonempty_string("arrow group name", group.name) for group in self.groups]
        if len(set(names)) != len(names):
            raise ValueError(f"arrow groups: two of one name in {names}; give each its own")
        for group in self.groups:
            scale = positive(f"{group.name}: newtons_per_metre", group.newtons_per_metre, unit="N/m")
            self._inputs.append(self.DeclareVectorInputPort(group.name, group.size))
            for i, arrow in enumerate(group.arrows):
                if not 0 <= arrow.offset <= group.size - 3:
                    raise ValueError(
                        f"arrow {group.name}/{i}: offset {arrow.offset} reads outside the input of "
                        f"size {group.size}; accepted: 0 to {group.size - 3}"
                    )
                path = f"{ARROWS_PATH}/{group.name}/{i}"
                self._arrows.append(
                    (path, int(plant.GetBodyByName(arrow.body).index()), np.asarray(arrow.point), scale)
                )
                meshcat.SetObject(f"{path}/shaft/cylinder", Cylinder(radius, 1.0), group.rgba)
                meshcat.SetTransform(f"{path}/shaft/cylinder", RigidTransform([0.0, 0.0, 0.5]))
                meshcat.SetObject(
                    f"{path}/head/cone", MeshcatCone(self._head, 3 * radius, 3 * radius), group.rgba
                )
                meshcat.SetTransform(
                    f"{path}/head/cone", RigidTransform(RotationMatrix.MakeXRotation(np.pi), [0, 0, 0])
                )
                meshcat.SetProperty(path, "visible", False)
        self.DeclarePeriodicPublishEvent(self._period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)

    def _publish(self, context: Context) -> None:
        t = recording_time(context.get_time(), self._period)
        poses = self._poses.Eval(context)
        arrows = iter(self._arrows)
        for group, port in zip(self.groups, self._inputs, strict=True):
            forces = port.Eval(context)
            for arrow in group.arrows:
                path, body, point, scale = next(arrows)
                force = forces[arrow.offset : arrow.offset + 3]
                length = float(np.linalg.norm(force)) / scale
                visible = length > SHORTEST_ARROW  # False for NaN
                self._meshcat.SetProperty(path, "visible", visible, time_in_recording=t)
                if not visible:
                    continue
                self._meshcat.SetTransform(
                    path, RigidTransform(RotationMatrix.MakeFromOneVector(force, 2), poses[body] @ point), t
                )
                self._meshcat.SetProperty(
                    f"{path}/shaft", "scale", [1.0, 1.0, max(length - self._head, 1e-4)], time_in_recording=t
                )
                self._meshcat.SetTransform(f"{path}/head", RigidTransform([0.0, 0.0, length]), t)


def pair_colour(distance: float, d_s: float, d_i: float) -> int:
    """Which of the :data:`PAIR_COLOURS` colours a pair ``distance`` [m] apart is drawn in: 0
    at ``d_i`` [m] and beyond, the last at ``d_s`` [m] and closer, linear between (rounded)."""
    nearness = (d_i - distance) / (d_i - d_s)
    return int(np.clip(np.rint(nearness * (PAIR_COLOURS - 1)), 0, PAIR_COLOURS - 1))


def _blend(share: float) -> Rgba:
    """The colour ``share`` of the way from :data:`FAR_COLOUR` to :data:`NEAR_COLOUR`."""
    far, near = FAR_COLOUR.rgba, NEAR_COLOUR.rgba
    return Rgba(*((1 - share) * far + share * near))


class PairLines(SotLeafSystem):
    """The pairs of collision shapes of a self-collision task, each drawn as a thin cylinder from
    its witness point on B to the one on A, coloured by its distance (:func:`pair_colour`: from
    :data:`FAR_COLOUR` at ``d_i`` to :data:`NEAR_COLOUR` at ``d_s``), in Meshcat and its
    recording, at ``period``. A row without a pair is hidden: nothing shows when no pair is
    closer than ``d_i``.

    Row ``i`` is ``/self_collision/<task>/<i>``: its transform puts the origin on the point on B
    and the z axis towards the point on A, the ``scale`` of its ``line`` gives the length, and
    ``line/<c>`` is the line in colour ``c`` (one visible). Only a shown row's transform, scale
    and colours are sent: a hidden row's line is hidden with it.

    Input ports:
        closest_pairs: abstract ``tuple[ClosestPair, ...]`` (the task's ``closest_pairs``: the
            pairs' distances [m] and witness points in world [m]).

    Args:
        meshcat: where to draw.
        task: the task's name (its Meshcat path; the legend names it).
        rows: the task's number of rows (``max_pairs``), >= 1.
        d_s: the task's safety margin [m].
        d_i: the task's activation distance [m], > ``d_s``.
        period: [s] how often they are drawn, finite and > 0 (1/30 s: the visualizer's rate).
        radius: [m] the lines' radius, finite and > 0.

    Attributes:
        task, d_s, d_i: as given (for a legend).

    Raises:
        ValueError: an empty ``task``, ``rows`` < 1, ``d_i`` not > ``d_s``, a ``period`` or
            ``radius`` that is not finite and > 0 (each named).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        task: str,
        rows: int,
        d_s: float,
        d_i: float,
        *,
        period: float = 1 / 30,
        radius: float = 0.003,
    ) -> None:
        super().__init__()
        self.task = nonempty_string("task", task)
        self.set_name(f"pair_lines_{task}")
        self._meshcat = meshcat
        self.d_s, self.d_i = float(d_s), float(d_i)
        if not (self.d_i > self.d_s):
            raise ValueError(f"{task!r}: d_i = {d_i!r} m: must be > d_s = {d_s!r} m")
        radius = positive("radius", radius, unit="m")
        self._period = positive("period", period, unit="s")
        self._paths = [f"{PAIRS_PATH}/{task}/{i}" for i in range(positive_int(f"{task!r}: rows", rows))]
        for path in self._paths:
            for c in range(PAIR_COLOURS):
                cylinder = f"{path}/line/{c}/cylinder"
                meshcat.SetObject(cylinder, Cylinder(radius, 1.0), _blend(c / (PAIR_COLOURS - 1)))
                meshcat.SetTransform(cylinder, RigidTransform([0.0, 0.0, 0.5]))
            meshcat.SetProperty(path, "visible", False)
        self._pairs = self.DeclareAbstractInputPort("closest_pairs", AbstractValue.Make(()))
        self.DeclarePeriodicPublishEvent(self._period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)

    def _publish(self, context: Context) -> None:
        t = recording_time(context.get_time(), self._period)
        pairs = self._pairs.Eval(context)
        for i, path in enumerate(self._paths):
            shown = i < len(pairs)
            self._meshcat.SetProperty(path, "visible", shown, time_in_recording=t)
            if not shown:
                continue
            pair = pairs[i]
            p_WCa, p_WCb = np.asarray(pair.p_WCa), np.asarray(pair.p_WCb)
            length = float(np.linalg.norm(p_WCa - p_WCb))
            R = RotationMatrix.MakeFromOneVector(p_WCa - p_WCb, 2) if length > 1e-9 else RotationMatrix()
            self._meshcat.SetTransform(path, RigidTransform(R, p_WCb), t)
            self._meshcat.SetProperty(
                f"{path}/line", "scale", [1.0, 1.0, max(length, 1e-4)], time_in_recording=t
            )
            colour = pair_colour(pair.distance, self.d_s, self.d_i)
            for c in range(PAIR_COLOURS):
                self._meshcat.SetProperty(f"{path}/line/{c}", "visible", c == colour, time_in_recording=t)


class FollowCamera(SotLeafSystem):
    """Moves the Meshcat viewer's camera (:data:`CAMERA_PATH`) with a body of the plant (the
    pelvis), in the horizontal plane. The camera is first put at :data:`CAMERA_OFFSET` looking
    at :data:`CAMERA_TARGET_HEIGHT` above the world's origin; then its frame is translated by
    the body's (x, y), so the view keeps its height and direction as the robot walks. Moved at
    ``period`` (and by ``ForcedPublish``) while the parameter ``follow`` is 1; :meth:`set_follow`
    leaves the camera where it was first put.

    Input ports:
        body_poses: abstract ``list[RigidTransform]`` (the plant's ``body_poses``).

    Args:
        meshcat: whose camera to move.
        plant: the simulated (finalized) plant.
        body: the name of the body followed.
        period: [s] how often the camera moves, finite and > 0.

    Raises:
        ValueError: a ``period`` that is not finite and > 0.
        RuntimeError: a body the plant does not have (Drake's message names it).
    """

    def __init__(self, meshcat: Meshcat, plant: MultibodyPlant, body: str, *, period: float = 1 / 30) -> None:
        super().__init__()
        self.set_name("follow_camera")
        self._meshcat = meshcat
        self._body = int(plant.GetBodyByName(body).index())
        meshcat.SetCameraPose(np.array(CAMERA_OFFSET), np.array([0.0, 0.0, CAMERA_TARGET_HEIGHT]))
        self._poses = self.DeclareAbstractInputPort(
            "body_poses", plant.get_body_poses_output_port().Allocate()
        )
        self._follow = self.DeclareNumericParameter(BasicVector([1.0]))
        self._period = positive("period", period, unit="s")
        self.DeclarePeriodicPublishEvent(self._period, 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)

    def set_follow(self, context: Context, follow: bool) -> None:
        """Follow the body (True, the default) or leave the camera where it is (False), in
        ``context`` (this system's)."""
        context.get_mutable_numeric_parameter(self._follow).SetAtIndex(0, 1.0 if follow else 0.0)

    def _publish(self, context: Context) -> None:
        if context.get_numeric_parameter(self._follow)[0] > 0.5:
            x, y, _ = self._poses.Eval(context)[self._body].translation()
            time = recording_time(context.get_time(), self._period)
            self._meshcat.SetTransform(CAMERA_PATH, RigidTransform([x, y, 0.0]), time)
