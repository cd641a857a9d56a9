"""A first description file of a robot, drafted from its model (``drake-sot robot draft MODEL``).

:func:`draft_description` reads a model (a URDF, an SDF or an MJCF, through
:mod:`~drake_sot.robots.model_tree`) and guesses, from the link names and the kinematic tree in
the zero configuration, what :mod:`~drake_sot.robots.description_file` asks:

- the sides: a link is left or right when a word of its name says so (``left``, ``l``, ``L``
  before a capital: ``l_knee``, ``left_hip_link``, ``LAnkle``);
- the feet: on each side the lowest link; the sole under it, at the bottom of its box (visual
  or collision) when it has one, which gives the sole's size too; the ankle: the child of the
  last revolute joint above the foot; the ankle's force sensor: a fixed joint between the two,
  else a sole link welded under the foot (an added weld; in an MJCF, a body, the weld named as
  Drake names it);
- the legs: the subtree of the first sided link on the way from the base to the foot; the
  arms: the other sided links; the hand: the arm's link named hand, palm, gripper or tool (else
  its deepest link); the wrist and its sensor: the fixed joint nearest above the hand;
- the head: the deepest link named head (else the highest link of neither side), its camera on
  its origin with the optical axes; the torso: the deepest link named torso, chest or trunk
  (else the last common ancestor of the hands); the pelvis and waist: the base (the root link);
- the half-sitting posture: each knee (a revolute joint named knee) bent by :data:`KNEE_BEND`
  within its limits, the hip and ankle joints of the leg about a parallel axis turned back by
  half as much so that the sole stays flat; every other joint at 0 (or its nearest limit);
- the drives: ``kp`` from the joint's effort limit (:data:`KP_PER_EFFORT`), ``kd`` from ``kp``.

What it could not guess, or guessed on weak grounds, is listed in comments at the top of the
draft, to check before use. No pydrake import here.
"""

from __future__ import annotations

import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

from drake_sot.robots.description import FORCE_SENSORS, LOGICAL_FRAMES, OPTICAL_RPY
from drake_sot.robots.errors import RobotFileError
from drake_sot.robots.model_tree import ModelTree, read_model_tree, weld_name

#: The knee bend [rad] of a drafted half-sitting posture (HRP-2 bends its knees 0.87 rad).
KNEE_BEND = 0.6
#: A drafted ``kp`` [N m/rad] per N m of the joint's effort limit: the servo reaches its effort
#: limit at a 0.05 rad error (the embedded humanoid's legs: 20-25).
KP_PER_EFFORT = 20.0
#: A drafted ``kd`` is ``kp`` divided by this [s^-1] (the embedded humanoid's legs: 75-85).
KD_RATIO = 80.0
#: Effort limit [N m] drafted for a joint whose model gives none (or zero).
DEFAULT_EFFORT = 10.0
#: Sole size [m] drafted when the foot has no box to read it from.
DEFAULT_SOLE = (0.2, 0.1)

_SIDES = {
    "left": re.compile(r"(^|[^a-z])(l|left)([^a-z]|$)|^L[A-Z]", re.IGNORECASE),
    "right": re.compile(r"(^|[^a-z])(r|right)([^a-z]|$)|^R[A-Z]", re.IGNORECASE),
}


@dataclass
class Draft:
    """A drafted description: the TOML text, and the list of what it could not guess."""

    text: str
    unguessed: list[str] = field(default_factory=list)


def _printable(name: str) -> bool:
    """True when ``name`` is text a TOML string holds as it is (no control character, no lone
    surrogate)."""
    try:
        name.encode("utf-8")
    except UnicodeEncodeError:
        return False
    return name.isprintable()


def _side(name: str) -> str | None:
    sides = [side for side, pattern in _SIDES.items() if pattern.search(name)]
    return sides[0] if len(sides) == 1 else None


def _key(name: str) -> str:
    """A TOML key: bare when it can be, else quoted."""
    return name if re.fullmatch(r"[A-Za-z0-9_-]+", name) else json.dumps(name, ensure_ascii=False)


def _value(value) -> str:
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, tuple | list):
        return "[" + ", ".join(_value(v) for v in value) + "]"
    return repr(round(float(value), 6) + 0.0)  # + 0.0: no -0.0


def _named(model: ModelTree, links, pattern: str) -> list[str]:
    """The ``links`` whose names match ``pattern``, those with a mass if any has one."""
    found = [link for link in links if re.search(pattern, link, re.IGNORECASE)]
    return [link for link in found if model.links[link].massive] or found


def draft_description(path: str | Path) -> Draft:
    """A description file for the model ``path`` (a URDF, an SDF or an MJCF; to be written
    beside it, named as it with ``.toml``): see the module docstring for what it guesses and how.

    Raises:
        RobotFileMissing: ``path`` does not exist.
        RobotFileError: an unknown suffix, not well-formed XML, not the format its suffix says,
            a feature :mod:`~drake_sot.robots.model_tree` refuses, no single root link, a joint
            that cannot be read, or not two sides with a foot each (naming the file).
    """
    path = Path(path)
    model = read_model_tree(path)
    unwritable = [name for name in (*model.links, *model.joints) if not _printable(name)]
    if unwritable:
        raise RobotFileError(f"robot model file {path}: names {unwritable} are not printable text")
    unguessed: list[str] = []
    frames: dict[str, str | dict] = {}
    sensors: dict[str, str] = {}
    welds: list[dict] = []
    depth = {link: len(model.chain(link)) for link in model.links}
    height = {link: model.pose[link][1][2] for link in model.links}
    sided = {side: [link for link in model.links if _side(link) == side] for side in _SIDES}
    for side, links in sided.items():
        if not links:
            raise RobotFileError(f"robot model file {path}: no {side} link (no link name says {side!r})")
    frames["pelvis"] = frames["waist"] = model.root
    sole_size = None
    hands = {}
    for side, links in sided.items():
        foot = min(links, key=lambda link: (height[link], -depth[link]))
        chain = model.chain(foot)
        ankle = next(
            (
                link
                for link in reversed(chain)
                if link in model.by_child and model.by_child[link].kind == "revolute"
            ),
            foot,
        )
        box = model.links[foot].box
        if box is None:
            sole_xyz = (0.0, 0.0, 0.0)
            unguessed.append(
                f"{side} sole: {foot!r} has no box; the sole is put on its origin, size {DEFAULT_SOLE}"
            )
        else:
            size, centre = box
            sole_xyz = (float(centre[0]), float(centre[1]), float(centre[2] - size[2] / 2))
            sole_size = sole_size or (float(size[0]), float(size[1]))
        welded = [
            model.by_child[link]
            for link in chain[chain.index(ankle) + 1 :]
            if model.by_child[link].kind == "fixed"
        ]
        if welded:
            sensors[f"{side}_ankle"] = welded[0].name
            frames[f"{side}_foot"] = {"parent": foot, "xyz": sole_xyz}
        else:
            child = f"{side}_sole_link"
            name = weld_name(model.format, foot, child, f"{side}_ankle_ft")
            weld = {"name": name, "parent": foot, "child": child, "xyz": sole_xyz}
            welds.append(weld)
            sensors[f"{side}_ankle"] = weld["name"]
            frames[f"{side}_foot"] = weld["child"]
        frames[f"{side}_ankle"] = ankle
        leg = model.subtree(next(link for link in chain if _side(link) == side))
        arm = [link for link in links if link not in leg]
        if not arm:
            raise RobotFileError(f"robot model file {path}: no {side} arm (every {side} link is in the leg)")
        candidates = _named(model, arm, r"hand|palm|gripper|tool") or _named(model, arm, r"wrist")
        hand = (
            min(candidates, key=lambda link: depth[link])
            if candidates
            else max(arm, key=lambda link: depth[link])
        )
        if not candidates:
            unguessed.append(f"{side}_hand: no link named hand, palm, gripper or tool; the deepest arm link")
        unguessed.append(f"{side}_hand: the tool point is put on the origin of {hand!r}: give its xyz")
        hands[side] = hand
        frames[f"{side}_hand"] = hand
        hand_chain = model.chain(hand)
        fixed = [
            model.by_child[link]
            for link in reversed(hand_chain)
            if model.by_child.get(link) and model.by_child[link].kind == "fixed"
        ]
        if fixed:
            sensors[f"{side}_wrist"] = fixed[0].name
            frames[f"{side}_wrist"] = fixed[0].parent
        else:
            joint = model.by_child[hand]
            sensors[f"{side}_wrist"] = joint.name
            frames[f"{side}_wrist"] = joint.parent
            unguessed.append(
                f"{side}_wrist sensor: no weld above the hand; {joint.name!r} is not one: add a weld"
            )
    centre = [link for link in model.links if _side(link) is None]
    heads = _named(model, centre, r"head")
    head = max(heads, key=lambda link: depth[link]) if heads else max(centre, key=lambda link: height[link])
    if not heads:
        unguessed.append(f"head: no link named head; the highest link of neither side, {head!r}")
    frames["head"] = head
    frames["head_camera"] = {"parent": head, "rpy": OPTICAL_RPY}
    unguessed.append(
        f"head_camera: put on the origin of {head!r} with the optical axes (z forward): give its xyz"
    )
    torsos = _named(model, centre, r"torso|chest|trunk")
    if torsos:
        frames["torso"] = max(torsos, key=lambda link: depth[link])
    else:
        left, right = model.chain(hands["left"]), model.chain(hands["right"])
        frames["torso"] = [a for a, b in zip(left, right, strict=False) if a == b][-1]
        unguessed.append(
            f"torso: no link named torso, chest or trunk; the hands' common ancestor {frames['torso']!r}"
        )
    if sole_size is None:
        sole_size = DEFAULT_SOLE

    packages = sorted(set(re.findall(r"package:///?([^/\"']+)/", path.read_text(errors="replace"))))
    for package in packages:
        unguessed.append(f"packages: the model's files are in package {package!r}: give its directory")
    half_sitting = _half_sitting(model, unguessed)
    drives = []
    for joint in model.moving():
        pattern = _key(f"^{re.escape(joint.name)}$")
        if joint.effort is not None and joint.effort > 0:  # not NaN
            kp = KP_PER_EFFORT * joint.effort
            drives.append(f"{pattern} = {{ kp = {_value(kp)}, kd = {_value(kp / KD_RATIO)} }}")
        else:
            kp = KP_PER_EFFORT * DEFAULT_EFFORT
            effort = f"effort = {_value(DEFAULT_EFFORT)}"
            drives.append(f"{pattern} = {{ kp = {_value(kp)}, kd = {_value(kp / KD_RATIO)}, {effort} }}")
            unguessed.append(f"drives: {joint.name!r} has no effort limit; {DEFAULT_EFFORT:g} N m drafted")
    lines = [
        f"# drafted by `drake-sot robot draft {path.name}`: check every line, and first what follows.",
        *(f"# NOT GUESSED: {item}" for item in unguessed),
        "",
        f"name = {_value(path.stem)}",
        f"model = {_value(path.name)}",
        f"base_body = {_value(model.root)}",
        f"sole_size = {_value(sole_size)}  # [m] length (x), width (y)",
        "contact_radius = 0.01  # [m]",
        "",
    ]
    if packages:
        lines += ["[packages]  # name = directory (relative to this file)"]
        lines += [f'# {_key(package)} = "..."' for package in packages] + [""]
    lines += ["[frames]"]
    for key in LOGICAL_FRAMES:
        spec = frames[key]
        if isinstance(spec, str):
            lines.append(f"{key} = {_value(spec)}")
        else:
            items = ", ".join(f"{k} = {_value(v)}" for k, v in spec.items())
            lines.append(f"{key} = {{ {items} }}")
    lines += ["", "[force_sensors]", *(f"{key} = {_value(sensors[key])}" for key in FORCE_SENSORS)]
    for weld in welds:
        lines += ["", "[[added_welds]]", *(f"{k} = {_value(v)}" for k, v in weld.items())]
    lines += ["", "[half_sitting]  # [rad]", *(f"{_key(j)} = {_value(a)}" for j, a in half_sitting.items())]
    lines += [
        "",
        f"# kp = {KP_PER_EFFORT:g} x the effort limit, kd = kp / {KD_RATIO:g}: tune them",
        "[drives]",
    ]
    lines += drives
    return Draft("\n".join(lines) + "\n", unguessed)


def _half_sitting(model: ModelTree, unguessed: list[str]) -> dict[str, float]:
    """Each moving joint's drafted angle: the knees bent, the hips and ankles of their legs
    turned back about parallel axes by half as much, every other joint at 0 or its nearest limit."""
    angles = {}
    for joint in model.moving():
        lower, upper = joint.limits
        angles[joint.name] = min(max(0.0, lower), upper)
    knees = [j for j in model.moving() if re.search(r"knee", j.name, re.IGNORECASE)]
    if not knees:
        unguessed.append("half_sitting: no joint named knee; every joint at 0 (or its nearest limit)")
    for knee in knees:
        lower, upper = knee.limits
        bend = KNEE_BEND if upper >= KNEE_BEND else -KNEE_BEND if lower <= -KNEE_BEND else 0.0
        angles[knee.name] = bend
        axis = model.pose[knee.child][0] @ knee.axis
        chain = model.chain(knee.child)
        below = [
            model.by_child[link]
            for link in sorted(
                model.subtree(knee.child) - {knee.child}, key=lambda link: len(model.chain(link))
            )
            if model.by_child[link].kind == "revolute"
        ]
        above = [model.by_child[link] for link in chain[1:-1] if model.by_child[link].kind == "revolute"]
        for group, what in ((above[::-1], "hip"), (below, "ankle")):
            for joint in group:
                other = model.pose[joint.child][0] @ joint.axis
                dot = float(axis @ other)
                if abs(dot) > 0.9:
                    lo, hi = joint.limits
                    angles[joint.name] = min(max(-0.5 * bend * math.copysign(1.0, dot), lo), hi)
                    break
            else:
                unguessed.append(
                    f"half_sitting: no {what} joint parallel to {knee.name!r}; the sole may tilt"
                )
    return angles
