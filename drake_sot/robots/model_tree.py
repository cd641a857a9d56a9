"""What a robot's model file says, whatever its format: the kinematic tree in the zero
configuration and the table of its moving joints.

A model is a URDF (``.urdf``), an SDF (``.sdf``: one ``<model>``) or an MJCF (``.xml`` whose
root is ``<mujoco>``), the three formats Drake's ``Parser`` reads. :func:`read_model_tree` reads
one into a :class:`ModelTree` (links, joints, poses) for the draft of a description
(:mod:`~drake_sot.robots.draft`); :func:`model_joints` gives the moving joints' limits and effort
limits for the description's check of its half-sitting angles and drives.

The tree is the one Drake's parser builds, names included; its moving joints, which the loader
drives, are the revolute ones with their limits (a continuous or prismatic joint is not driven):

- URDF: links and joints as named; a ``<mimic>`` joint is not a moving joint (the loader fixes
  it); a revolute joint needs ``<limit lower upper effort>``;
- SDF: links placed by ``<pose relative_to>`` (the model by default; a link, a joint or a
  ``<frame>`` of the model), joints on their child link by default, axes in the joint frame
  (or ``expressed_in``), ``degrees="true"`` read; a limit ``<effort>`` absent or negative
  (SDFormat's "unlimited") leaves the effort to the description; nested models, ``<include>``
  and quaternion poses are refused;
- MJCF: nested ``<body>`` elements, ``<default>`` classes applied, angles in degrees unless
  ``<compiler angle="radian">``, orientations as ``quat``, ``axisangle``, ``euler`` (the
  compiler's ``eulerseq``), ``xyaxes`` or ``zaxis``; the one top body with a ``<freejoint>``
  (or a ``free`` joint) is the floating base; a body without a joint is welded to its parent
  by a joint that Drake names ``<parent>_welds_to_<child>`` (:func:`weld_name`: the force
  sensor welds of an MJCF are named so); a body of several joints gets Drake's massless
  intermediate bodies ``<body>0``, ``<body>1``…; a hinge without ``range`` is unlimited; the
  effort limit is the smallest of the joint's ``actuatorfrcrange`` and of its actuators'
  ``forcerange`` (and a motor's ``ctrlrange``), else left to the description; ``<include>``
  is refused.

No pydrake import here: XML in, numbers out.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from drake_sot.robots.errors import RobotFileError, RobotFileMissing
from drake_sot.robots.model_values import check_model_values

#: The model formats by file suffix (an ``.xml`` must be MJCF: its root ``<mujoco>``).
MODEL_FORMATS = {".urdf": "urdf", ".sdf": "sdf", ".xml": "mjcf"}
#: The root element of each format.
_ROOTS = {"urdf": "robot", "sdf": "sdf", "mjcf": "mujoco"}
_X = np.array([1.0, 0.0, 0.0])  # a URDF joint's default axis
_Z = np.array([0.0, 0.0, 1.0])  # an MJCF joint's default axis


@dataclass(frozen=True)
class ModelJoint:
    """A moving joint as the model declares it: limits [rad] and effort limit [N m] (None when
    the model gives none: the description's drive must)."""

    lower: float
    upper: float
    effort: float | None


@dataclass
class TreeJoint:
    """A joint of the tree: ``kind`` "revolute", "fixed" or another (prismatic, ball…, never
    driven); the child's frame in the parent's (rotation ``R``, position ``p`` [m]) in the zero
    configuration; the axis in the child's frame; a revolute joint's limits and effort."""

    name: str
    kind: str
    parent: str
    child: str
    R: np.ndarray
    p: np.ndarray
    axis: np.ndarray
    limits: tuple[float, float] | None = None
    effort: float | None = None
    follower: bool = False  # a URDF <mimic> joint


@dataclass
class TreeLink:
    """A link of the tree: whether it has mass, and a box of it (size, centre [m] in its frame)."""

    name: str
    massive: bool
    box: tuple[np.ndarray, np.ndarray] | None


def rotation(rpy) -> np.ndarray:
    """The rotation matrix of roll-pitch-yaw ``rpy`` [rad] (URDF and SDF: about fixed x, y, z)."""
    roll, pitch, yaw = rpy
    cr, sr, cp, sp, cy, sy = (math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch),
                              math.cos(yaw), math.sin(yaw))  # fmt: skip
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def _axis_angle(axis, angle: float) -> np.ndarray:
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    return np.eye(3) + math.sin(angle) * K + (1.0 - math.cos(angle)) * K @ K


def _floats(text: str | None, size: int, default: np.ndarray | None = None) -> np.ndarray:
    if text is None:
        return np.zeros(size) if default is None else default
    values = [float(v) for v in text.split()]
    if len(values) != size:
        raise ValueError(f"{text!r}: needs {size} numbers")
    return np.array(values)


def model_format(path: str | Path) -> str:
    """The format of model file ``path`` by its suffix: "urdf", "sdf" or "mjcf".

    Raises RobotFileError naming the file and the suffixes accepted.
    """
    path = Path(path)
    try:
        return MODEL_FORMATS[path.suffix.lower()]
    except KeyError:
        raise RobotFileError(
            f"robot model file {path}: a model is a URDF (.urdf), an SDF (.sdf) or an MJCF (.xml)"
        ) from None


def model_root(path: str | Path) -> tuple[str, ET.Element]:
    """The format of model file ``path`` and the root element of its XML.

    Raises:
        RobotFileMissing: ``path`` is not a file.
        RobotFileError: an unknown suffix, not well-formed XML (truncated, garbage), or a root
            element not the format's (an ``.xml`` that is not MJCF, say), naming the file.
    """
    fmt = model_format(path)
    if not Path(path).is_file():
        raise RobotFileMissing(f"robot model file {path} does not exist")
    try:
        root = ET.parse(path).getroot()
    except ET.ParseError as exc:
        raise RobotFileError(
            f"robot model file {path}: not well-formed XML ({exc}): truncated or corrupt?"
        ) from None
    if root.tag != _ROOTS[fmt]:
        what = {"urdf": "a URDF", "sdf": "an SDF", "mjcf": "an MJCF (MuJoCo) model"}[fmt]
        raise RobotFileError(
            f"robot model file {path}: not {what} (its root is <{root.tag}>, not <{_ROOTS[fmt]}>)"
        )
    return fmt, root


def weld_name(fmt: str, parent: str, child: str, name: str) -> str:
    """The name the plant gives the weld of ``child`` to ``parent`` that a model of format
    ``fmt`` would call ``name``: an MJCF body has no joint to name, Drake names its weld."""
    return f"{parent}_welds_to_{child}" if fmt == "mjcf" else name


class ModelTree:
    """The kinematic tree of a model in its zero configuration: links, joints, the root, each
    link's pose (rotation, position [m]) in the root's frame."""

    def __init__(self, path: Path, fmt: str, links: list[TreeLink], joints: list[TreeJoint]) -> None:
        self.path = path
        self.format = fmt
        self.links = {link.name: link for link in links}
        if None in self.links or "" in self.links or len(self.links) != len(links):
            raise RobotFileError(f"robot model file {path}: a link without a name, or two of one name")
        self.joints = {joint.name: joint for joint in joints}
        if None in self.joints or "" in self.joints or len(self.joints) != len(joints):
            raise RobotFileError(f"robot model file {path}: a joint without a name, or two of one name")
        for j in joints:
            if j.parent not in self.links or j.child not in self.links:
                raise RobotFileError(
                    f"robot model file {path}: joint {j.name!r} joins {j.parent!r} to {j.child!r}: "
                    "both must be links of the model"
                )
        self.by_child = {j.child: j for j in joints}
        if len(self.by_child) != len(joints):
            twice = sorted({j.child for j in joints if self.by_child[j.child] is not j})
            raise RobotFileError(
                f"robot model file {path}: links {twice} are the child of two joints (a closed loop): "
                "a robot here is a tree"
            )
        self.children: dict[str, list[str]] = {name: [] for name in self.links}
        for j in joints:
            self.children[j.parent].append(j.child)
        roots = [name for name in self.links if name not in self.by_child]
        if len(roots) != 1:
            raise RobotFileError(f"robot model file {path}: needs one root link, has {roots or 'none'}")
        self.root = roots[0]
        self.pose: dict[str, tuple[np.ndarray, np.ndarray]] = {}
        stack = [(self.root, np.eye(3), np.zeros(3))]
        while stack:
            link, R, p = stack.pop()
            self.pose[link] = (R, p)
            for child in self.children[link]:
                j = self.by_child[child]
                stack.append((child, R @ j.R, p + R @ j.p))
        detached = sorted(set(self.links) - set(self.pose))
        if detached:
            raise RobotFileError(
                f"robot model file {path}: links {detached} are not below the root {self.root!r}"
            )

    def chain(self, link: str) -> list[str]:
        """The links from the root to ``link``, both included."""
        links = [link]
        while links[-1] in self.by_child:
            links.append(self.by_child[links[-1]].parent)
        return links[::-1]

    def subtree(self, link: str) -> set[str]:
        found, stack = set(), [link]
        while stack:
            found.add(stack[-1])
            stack.extend(self.children[stack.pop()])
        return found

    def moving(self) -> list[TreeJoint]:
        """The revolute joints (mimic followers left out: the loader fixes them)."""
        return [j for j in self.joints.values() if j.kind == "revolute" and not j.follower]

    def model_joints(self, frozen: tuple[str, ...] = ()) -> dict[str, ModelJoint]:
        """The moving joints (less the ``frozen`` ones) with their limits and effort, in file order."""
        return {
            j.name: ModelJoint(j.limits[0], j.limits[1], j.effort)
            for j in self.moving()
            if j.name not in frozen
        }


def read_model_tree(path: str | Path) -> ModelTree:
    """The tree of the model file ``path`` (see the module docstring for what each format gives).

    Raises:
        RobotFileMissing: ``path`` does not exist.
        RobotFileError: an unknown suffix, not well-formed XML, not the format its suffix says,
            a number out of range (a mass, an inertia, an origin: see
            :mod:`~drake_sot.robots.model_values`), an element that cannot be read (a joint, a
            pose, a limit), a feature refused (see the module docstring), not a tree with one
            root; each naming the file.
    """
    path = Path(path)
    fmt, root = model_root(path)
    check_model_values(path, fmt, root)
    reader = {"urdf": _Urdf, "sdf": _Sdf, "mjcf": _Mjcf}[fmt](path, root)
    return ModelTree(path, fmt, *reader.read())


def model_joints(path: str | Path, frozen: tuple[str, ...] = ()) -> dict[str, ModelJoint]:
    """The moving joints of model file ``path`` (less the ``frozen`` ones), in file order.

    Raises RobotFileMissing or RobotFileError as :func:`read_model_tree`.
    """
    return read_model_tree(path).model_joints(frozen)


class _Reader:
    """Reads one format into (links, joints); errors name the file."""

    def __init__(self, path: Path, root: ET.Element) -> None:
        self.path = path
        self.root = root

    def error(self, what: str) -> RobotFileError:
        return RobotFileError(f"robot model file {self.path}: {what}")


class _Urdf(_Reader):
    def read(self) -> tuple[list[TreeLink], list[TreeJoint]]:
        links = [
            TreeLink(link.get("name"), self.mass(link) > 0.0, self.box(link))
            for link in self.root.findall("link")
        ]
        joints = []
        for element in self.root.findall("joint"):
            name, kind = element.get("name"), element.get("type")
            try:
                origin, limit, axis = element.find("origin"), element.find("limit"), element.find("axis")
                revolute = kind == "revolute"
                joints.append(
                    TreeJoint(
                        name=name,
                        kind=kind,
                        parent=element.find("parent").get("link"),
                        child=element.find("child").get("link"),
                        R=rotation(_floats(None if origin is None else origin.get("rpy"), 3)),
                        p=_floats(None if origin is None else origin.get("xyz"), 3),
                        axis=_X if axis is None else _floats(axis.get("xyz"), 3),
                        limits=(float(limit.get("lower")), float(limit.get("upper"))) if revolute else None,
                        effort=float(limit.get("effort")) if revolute else None,
                        follower=element.find("mimic") is not None,
                    )
                )
            except (AttributeError, TypeError, ValueError) as exc:
                needs = " (a revolute joint needs <limit lower upper effort>)" if kind == "revolute" else ""
                raise self.error(f"joint {name!r}: cannot be read{needs}: {exc}") from None
        return links, joints

    @staticmethod
    def mass(link: ET.Element) -> float:
        mass = link.find("inertial/mass")
        try:
            return float(mass.get("value"))
        except (AttributeError, TypeError, ValueError):
            return 0.0

    def box(self, link: ET.Element) -> tuple[np.ndarray, np.ndarray] | None:
        for tag in ("collision", "visual"):
            for geometry in link.findall(tag):
                box = geometry.find("geometry/box")
                if box is not None:
                    origin = geometry.find("origin")
                    try:
                        return _floats(box.get("size"), 3), _floats(
                            origin.get("xyz") if origin is not None else None, 3
                        )
                    except ValueError as exc:
                        raise self.error(
                            f"the box of link {link.get('name')!r} cannot be read: {exc}"
                        ) from None
        return None


class _Sdf(_Reader):
    def read(self) -> tuple[list[TreeLink], list[TreeJoint]]:
        models = self.root.findall("model")
        if len(models) != 1 or self.root.find("world") is not None:
            raise self.error(
                f"an SDF robot is one <model> under <sdf>; it has {len(models)} (and no <world>)"
            )
        model = models[0]
        for tag in ("model", "include"):
            if model.find(tag) is not None:
                raise self.error(f"<{tag}> in the model: nested models are not read; give one flat model")
        self.frames: dict[str, tuple[ET.Element | None, str]] = {}  # name -> (pose, relative to)
        for link in model.findall("link"):
            self.frames[link.get("name")] = (link.find("pose"), "__model__")
        for frame in model.findall("frame"):
            self.frames[frame.get("name")] = (frame.find("pose"), frame.get("attached_to") or "__model__")
        for joint in model.findall("joint"):
            self.frames[joint.get("name")] = (joint.find("pose"), joint.findtext("child", "").strip())
        self.resolved: dict[str, tuple[np.ndarray, np.ndarray]] = {"__model__": (np.eye(3), np.zeros(3))}
        links = []
        for link in model.findall("link"):
            mass = link.findtext("inertial/mass")
            try:
                massive = mass is None or float(mass) > 0.0  # SDFormat's default mass is 1 kg
            except ValueError:
                raise self.error(f"link {link.get('name')!r}: mass {mass!r} is not a number") from None
            links.append(TreeLink(link.get("name"), massive, self.box(link)))
        joints = []
        for element in model.findall("joint"):
            name, kind = element.get("name"), element.get("type")
            parent, child = element.findtext("parent", "").strip(), element.findtext("child", "").strip()
            if parent == "world":
                raise self.error(f"joint {name!r} attaches the model to the world: a robot's base is free")
            if child not in self.frames or parent not in self.frames:
                raise self.error(
                    f"joint {name!r} joins {parent!r} to {child!r}: both must be links of the model"
                )
            R_P, p_P = self.frame_pose(parent)
            R_C, p_C = self.frame_pose(child)
            axis = element.find("axis")
            limits = effort = None
            try:
                if kind in ("revolute", "continuous"):
                    xyz = axis.find("xyz") if axis is not None else None
                    direction = _floats(None if xyz is None else xyz.text, 3, _Z)
                    expressed = None if xyz is None else xyz.get("expressed_in")
                    if axis is not None and axis.findtext("use_parent_model_frame", "").strip() == "true":
                        expressed = "__model__"
                    R_E = self.frame_pose(expressed or name)[0]
                    direction = R_C.T @ R_E @ direction
                    limit = axis.find("limit") if axis is not None else None
                    if kind == "revolute":  # a continuous joint is not driven, as in a URDF
                        lower = float(limit.findtext("lower", "-1e16")) if limit is not None else -1e16
                        upper = float(limit.findtext("upper", "1e16")) if limit is not None else 1e16
                        limits = (lower, upper)
                        value = float(limit.findtext("effort", "-1")) if limit is not None else -1.0
                        effort = value if value > 0.0 else None
                else:
                    direction = _Z
            except (AttributeError, TypeError, ValueError) as exc:
                raise self.error(f"joint {name!r}: its axis or limits cannot be read: {exc}") from None
            joints.append(
                TreeJoint(
                    name, kind, parent, child, R_P.T @ R_C, R_P.T @ (p_C - p_P), direction, limits, effort
                )
            )
        return links, joints

    def pose(self, element: ET.Element | None, where: str) -> tuple[np.ndarray, np.ndarray]:
        if element is None or not (element.text or "").strip():
            return np.eye(3), np.zeros(3)
        if element.get("rotation_format", "euler_rpy") != "euler_rpy":
            raise self.error(
                f"{where}: a pose with rotation_format={element.get('rotation_format')!r} is not read"
            )
        try:
            values = _floats(element.text, 6)
        except ValueError as exc:
            raise self.error(f"{where}: pose cannot be read: {exc}") from None
        if element.get("degrees", "false").strip() == "true":
            values[3:] = np.radians(values[3:])
        return rotation(values[3:]), values[:3]

    def frame_pose(self, name: str, seen: tuple[str, ...] = ()) -> tuple[np.ndarray, np.ndarray]:
        """The pose of frame ``name`` (a link, joint or <frame>) in the model frame."""
        if name in self.resolved:
            return self.resolved[name]
        if name not in self.frames or name in seen:
            raise self.error(f"frame {name!r} is unknown or defined through itself")
        element, default = self.frames[name]
        relative_to = (element.get("relative_to") if element is not None else None) or default
        R_F, p_F = self.frame_pose(relative_to, (*seen, name))
        R, p = self.pose(element, f"frame {name!r}")
        self.resolved[name] = (R_F @ R, p_F + R_F @ p)
        return self.resolved[name]

    def box(self, link: ET.Element) -> tuple[np.ndarray, np.ndarray] | None:
        for tag in ("collision", "visual"):
            for geometry in link.findall(tag):
                size = geometry.findtext("geometry/box/size")
                if size is not None:
                    where = f"the box of link {link.get('name')!r}"
                    try:
                        return _floats(size, 3), self.pose(geometry.find("pose"), where)[1]
                    except ValueError as exc:
                        raise self.error(f"{where} cannot be read: {exc}") from None
        return None


class _Mjcf(_Reader):
    #: The elements that <default> classes give attributes to, as read here.
    _DEFAULTED = ("joint", "geom", "motor", "position", "velocity", "general")

    def read(self) -> tuple[list[TreeLink], list[TreeJoint]]:
        if self.root.find(".//include") is not None:
            raise self.error("<include> is not read: give the robot in one MJCF file")
        compiler = self.root.find("compiler")
        compiler = {} if compiler is None else compiler.attrib
        self.degrees = compiler.get("angle", "degree") == "degree"
        self.eulerseq = compiler.get("eulerseq", "xyz")
        self.autolimits = compiler.get("autolimits", "true") == "true"
        self.defaults: dict[str, dict[str, dict[str, str]]] = {}
        for default in self.root.findall("default"):
            self.read_default(default, {})
        efforts = self.actuator_efforts()
        world = self.root.find("worldbody")
        bodies = [] if world is None else world.findall("body")
        free = [body for body in bodies if self.free(body, "main")]
        if len(bodies) != 1 or len(free) != 1:
            raise self.error(
                f"an MJCF robot is one body under <worldbody> with a <freejoint> (its floating base); "
                f"top bodies {[b.get('name') for b in bodies]}, free {[b.get('name') for b in free]}"
            )
        links: list[TreeLink] = []
        joints: list[TreeJoint] = []
        stack = [(bodies[0], None, "main")]
        while stack:
            body, parent, parent_class = stack.pop()
            name = body.get("name")
            childclass = body.get("childclass", parent_class)
            R, p = self.body_pose(body, name)
            geoms = [self.attrs(g, childclass) for g in body.findall("geom")]
            inertial = body.find("inertial")
            try:
                massive = float(inertial.get("mass")) > 0.0 if inertial is not None else bool(geoms)
            except (TypeError, ValueError):
                raise self.error(f"body {name!r}: <inertial> needs a numeric mass") from None
            links.append(TreeLink(name, massive, self.box(geoms, name)))
            if parent is not None:
                body_joints = [self.attrs(j, childclass) for j in body.findall("joint")]
                if self.free(body, childclass):
                    raise self.error(
                        f"body {name!r}: a free joint below the base; a robot has one floating base"
                    )
                if not body_joints:
                    joints.append(
                        TreeJoint(weld_name("mjcf", parent, name, ""), "fixed", parent, name, R, p, _Z)
                    )
                for i, joint in enumerate(body_joints):
                    last = i == len(body_joints) - 1
                    child = name if last else f"{name}{i}"
                    if not last:
                        links.append(TreeLink(child, False, None))
                    X_PC = (R, p) if last else (np.eye(3), np.zeros(3))  # Drake's massless bodies
                    joints.append(self.joint(joint, parent, child, *X_PC, efforts))
                    parent = child
            stack.extend((child, name, childclass) for child in reversed(body.findall("body")))
        return links, joints

    def free(self, body: ET.Element, childclass: str) -> bool:
        """True when ``body`` has a <freejoint> or a joint of type free."""
        joints = body.findall("joint")
        return body.find("freejoint") is not None or any(
            self.attrs(j, childclass).get("type") == "free" for j in joints
        )

    def read_default(self, element: ET.Element, inherited: dict[str, dict[str, str]]) -> None:
        own = {tag: dict(inherited.get(tag, {})) for tag in self._DEFAULTED}
        for child in element:
            if child.tag in own:
                own[child.tag].update(child.attrib)
        self.defaults[element.get("class", "main")] = own
        for nested in element.findall("default"):
            self.read_default(nested, own)

    def attrs(self, element: ET.Element, childclass: str) -> dict[str, str]:
        """The element's attributes over those of its <default> class."""
        defaults = self.defaults.get(element.get("class", childclass), {}).get(element.tag, {})
        return {**defaults, **element.attrib}

    def angle(self, value: float) -> float:
        return math.radians(value) if self.degrees else value

    def body_pose(self, body: ET.Element, name: str) -> tuple[np.ndarray, np.ndarray]:
        a = body.attrib
        try:
            R, p = self.orientation(a), _floats(a.get("pos"), 3)
        except ValueError as exc:
            raise self.error(f"body {name!r}: its pose cannot be read: {exc}") from None
        if not np.all(np.isfinite(R)):
            raise self.error(f"body {name!r}: its orientation has no direction (a zero vector)")
        return R, p

    def orientation(self, a: dict[str, str]) -> np.ndarray:
        """The rotation of a body's frame in its parent's, from whichever attribute gives it."""
        with np.errstate(invalid="ignore", divide="ignore"):  # a zero vector: NaN, refused above
            if "quat" in a:
                w, *v = _floats(a["quat"], 4)  # a unit quaternion's turn, about v
                turn = np.linalg.norm(v)
                R = _axis_angle(v, 2.0 * math.atan2(turn, w)) if turn > 1e-12 else np.eye(3)
            elif "axisangle" in a:
                values = _floats(a["axisangle"], 4)
                R = _axis_angle(values[:3], self.angle(values[3]))
            elif "euler" in a:
                R = np.eye(3)
                for letter, value in zip(self.eulerseq, _floats(a["euler"], 3), strict=True):
                    turn = _axis_angle(np.eye(3)["xyz".index(letter.lower())], self.angle(value))
                    R = R @ turn if letter.islower() else turn @ R  # lower case: about the moved axes
            elif "xyaxes" in a:
                values = _floats(a["xyaxes"], 6)
                x = values[:3] / np.linalg.norm(values[:3])
                y = values[3:] - (values[3:] @ x) * x
                y /= np.linalg.norm(y)
                R = np.column_stack([x, y, np.cross(x, y)])
            elif "zaxis" in a:  # the smallest turn of z onto it
                z = _floats(a["zaxis"], 3) / np.linalg.norm(_floats(a["zaxis"], 3))
                turn = np.cross(_Z, z)
                if np.linalg.norm(turn) > 1e-12:
                    R = _axis_angle(turn, math.atan2(np.linalg.norm(turn), z @ _Z))
                else:
                    R = np.eye(3) if z[2] > 0 else np.diag([1.0, -1.0, -1.0])
            else:
                R = np.eye(3)
        return R

    def limited(self, attrs: dict[str, str], key: str) -> bool:
        flag = attrs.get(f"{key[:-5]}limited" if key != "range" else "limited", "auto")
        return flag == "true" or (flag == "auto" and self.autolimits and key in attrs)

    def joint(self, attrs, parent, child, R, p, efforts) -> TreeJoint:
        name, kind = attrs.get("name"), attrs.get("type", "hinge")
        try:
            axis = _floats(attrs.get("axis"), 3, _Z)
            limits = None
            if kind == "hinge":
                limits = (-math.inf, math.inf)
                if self.limited(attrs, "range"):
                    lower, upper = _floats(attrs.get("range"), 2)
                    limits = (self.angle(lower), self.angle(upper))
            effort = efforts.get(name)
            if self.limited(attrs, "actuatorfrcrange"):
                own = float(np.max(np.abs(_floats(attrs.get("actuatorfrcrange"), 2))))
                effort = own if effort is None else min(effort, own)
        except (TypeError, ValueError) as exc:
            raise self.error(f"joint {name!r}: its axis or range cannot be read: {exc}") from None
        if not np.linalg.norm(axis) > 0.0:
            raise self.error(f"joint {name!r}: axis {attrs.get('axis')!r} has no direction")
        kind = {"hinge": "revolute", "slide": "prismatic"}.get(kind, kind)
        return TreeJoint(name, kind, parent, child, R, p, axis / np.linalg.norm(axis), limits, effort)

    def actuator_efforts(self) -> dict[str, float]:
        """Joint → the smallest force limit [N m] of the actuators on it that give one."""
        efforts: dict[str, float] = {}
        for actuators in self.root.findall("actuator"):
            for element in actuators:
                attrs = self.attrs(element, "main")
                limits = []
                try:
                    if self.limited(attrs, "forcerange"):
                        limits.append(float(np.max(np.abs(_floats(attrs["forcerange"], 2)))))
                    if element.tag == "motor" and self.limited(attrs, "ctrlrange"):
                        limits.append(float(np.max(np.abs(_floats(attrs["ctrlrange"], 2)))))
                except ValueError as exc:
                    raise self.error(
                        f"actuator {attrs.get('name')!r}: a range cannot be read: {exc}"
                    ) from None
                joint = attrs.get("joint")
                if joint is not None and limits:
                    efforts[joint] = min([*limits, efforts.get(joint, math.inf)])
        return efforts

    def box(self, geoms: list[dict[str, str]], body: str) -> tuple[np.ndarray, np.ndarray] | None:
        for geom in geoms:
            if geom.get("type") == "box" and "fromto" not in geom:
                try:
                    return 2.0 * _floats(geom.get("size"), 3), _floats(geom.get("pos"), 3)
                except ValueError as exc:
                    raise self.error(f"the box of body {body!r} cannot be read: {exc}") from None
        return None
