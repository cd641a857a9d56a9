"""What a run keeps of its self-collision avoidance
(:class:`~drake_sot.systems.self_collision.SelfCollisionAvoidance`): the per-tick logs and the
run's closing report, by name.

The pairs a task's rows hold change from tick to tick; the logs keep, per task named
``<task>`` (arrays of the run's ``.npz``):

- ``collision/<task>/distance`` (T, max_pairs) [m]: each row's signed distance, closest first
  (column 0 is the closest pair's), NaN for a row without a pair (none closer than ``d_i``);
- ``collision/<task>/pair`` (T, max_pairs) int: each row's pair, an index into
  ``collision/<task>/pairs``, -1 for a row without one;
- ``collision/<task>/pairs`` (P,): the pairs the task watches, a structured array of fields
  ``shape_a``, ``shape_b`` (the shapes' names) and ``body_a``, ``body_b`` (their bodies');
- ``collision/<task>/margins`` (2,) [m]: the task's safety margin ``d_s`` and activation
  distance ``d_i``.

:func:`collision_report` says, from those arrays, which bodies were closest at the end of the
run and when the least distance was reached (the ``drake-sot`` run's summary prints it).
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from drake_sot.systems.self_collision import SelfCollisionAvoidance

#: The prefix of the arrays of the self-collision tasks.
PREFIX = "collision/"
#: The most pairs of bodies a report line lists (the closest ones).
REPORTED_PAIRS = 5


def distance_log(task_name: str) -> str:
    """The name of the log of the rows' distances of the task ``task_name``."""
    return f"{PREFIX}{task_name}/distance"


def pair_log(task_name: str) -> str:
    """The name of the log of the rows' pairs (indices) of the task ``task_name``."""
    return f"{PREFIX}{task_name}/pair"


def collision_arrays(task: SelfCollisionAvoidance, logged: np.ndarray) -> dict[str, np.ndarray]:
    """The arrays of ``task`` besides its distances: its pairs' indices (``logged``, the (T,
    max_pairs) log of its ``pair_indices``, as ints: -1 for no pair, or for a sample the log
    does not have), the names of its candidate pairs and its margins (module docstring)."""
    name = task.get_name()
    fields = ("shape_a", "shape_b", "body_a", "body_b")
    width = max((len(getattr(p, f)) for p in task.candidate_pairs for f in fields), default=1)
    pairs = np.array(
        [tuple(getattr(p, f) for f in fields) for p in task.candidate_pairs],
        dtype=[(f, f"U{width}") for f in fields],
    )
    return {
        pair_log(name): np.where(np.isnan(logged), -1, logged).astype(int),
        f"{PREFIX}{name}/pairs": pairs,
        f"{PREFIX}{name}/margins": np.array([task.d_s, task.d_i]),
    }


def collision_report(arrays: Mapping[str, np.ndarray]) -> list[str]:
    """Per self-collision task of the run's ``arrays`` (:func:`~drake_sot.diagrams.artifacts.log_arrays`),
    two lines: the least distance over the logged samples, with its pair of bodies and its
    time; and at the last sample, the pairs of bodies closer than ``d_i``, closest first (a pair
    of bodies by the least distance of their shapes; at most :data:`REPORTED_PAIRS`). No line for
    a run without the task."""
    lines = []
    time = arrays["time"]
    for key in sorted(k for k in arrays if k.startswith(PREFIX) and k.endswith("/margins")):
        name = key[len(PREFIX) : -len("/margins")]
        d_s, d_i = arrays[key]
        distance, index = arrays[distance_log(name)], arrays[pair_log(name)]
        pairs = arrays[f"{PREFIX}{name}/pairs"]
        bodies = [f"{a}–{b}" for a, b in zip(pairs["body_a"], pairs["body_b"], strict=True)]
        if not len(time) or np.isnan(distance).all():
            lines.append(f"{name}: no pair of shapes came closer than d_i = {d_i:g} m")
            continue
        sample, row = np.unravel_index(np.nanargmin(distance), distance.shape)
        least = distance[sample, row]
        margin = (
            f"outside the margin d_s = {d_s:g} m"
            if least >= d_s
            else f"{d_s - least:.4f} m inside the margin d_s = {d_s:g} m"
        )
        lines.append(
            f"{name}: least distance {least:.4f} m ({bodies[index[sample, row]]}) at "
            f"t = {time[sample]:.3f} s, {margin}"
        )
        closest: dict[str, float] = {}
        for d, k in zip(distance[-1], index[-1], strict=True):
            if k >= 0 and bodies[k] not in closest:  # rows closest first: a pair's first is its least
                closest[bodies[k]] = d
        at_end = f"{name}: at the end (t = {time[-1]:.3f} s), "
        if not closest:
            lines.append(at_end + f"no pair closer than d_i = {d_i:g} m")
            continue
        shown = [f"{pair} {d:.4f} m" for pair, d in list(closest.items())[:REPORTED_PAIRS]]
        more = len(closest) - len(shown)
        lines.append(
            at_end
            + f"closer than d_i = {d_i:g} m: "
            + ", ".join(shown)
            + (f" and {more} more pair{'s' if more > 1 else ''} of bodies" if more else "")
        )
    return lines
