"""``MeshcatMarker``: a sphere drawn in Meshcat (and in its recording) at a point given on an input."""

from __future__ import annotations

from pydrake.geometry import Meshcat, Rgba, Sphere
from pydrake.math import RigidTransform
from pydrake.systems.framework import Context

from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import nonempty_string, positive

#: The default colour of a marker.
ORANGE = Rgba(0.9, 0.3, 0.1, 1.0)


class MeshcatMarker(SotLeafSystem):
    """Shows a point of the world that is not a body of the plant (an object the robot looks
    at) as a sphere in Meshcat, moved at ``period``; while Meshcat records (e.g.
    ``MeshcatVisualizer.StartRecording``), every move is also a frame of the recording, so
    the sphere moves in the replay too. ``ForcedPublish`` moves it at once.

    Input ports:
        position: the point in world (3,) [m].

    Args:
        meshcat: where to draw.
        path: the Meshcat path of the sphere (e.g. ``"/drake_sot/object"``).
        radius: [m], finite and > 0.
        rgba: its colour.
        period: how often it is moved [s], finite and > 0 (1/30 s: the visualizer's rate).

    Raises:
        ValueError: an empty path, a radius or period that is not finite and > 0 (named).
    """

    def __init__(
        self,
        meshcat: Meshcat,
        path: str,
        *,
        radius: float = 0.03,
        rgba: Rgba = ORANGE,
        period: float = 1 / 30,
    ) -> None:
        super().__init__()
        self._path = nonempty_string("path", path)
        self.set_name(f"marker_{path.strip('/').replace('/', '_')}")
        self._meshcat = meshcat
        meshcat.SetObject(self._path, Sphere(positive("radius", radius, unit="m")), rgba)
        self._position = self.DeclareVectorInputPort("position", 3)
        self.DeclarePeriodicPublishEvent(positive("period", period, unit="s"), 0.0, self._publish)
        self.DeclareForcedPublishEvent(self._publish)

    def _publish(self, context: Context) -> None:
        self._meshcat.SetTransform(
            self._path, RigidTransform(self._position.Eval(context)), time_in_recording=context.get_time()
        )
