"""Write what a run produced: the replay (HTML), the diagram (SVG), the plots (PNG), the logs (NPZ).

Every file is written atomically: under a temporary name in the same directory, then renamed
over the final name (``os.replace``), so a writer killed half-way leaves either the previous
file or none, never a truncated one. :class:`Artefacts` writes a run's files one after the
other: one that cannot be written (a full disk) is recorded and the next is still attempted.
"""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import subprocess
import sys
import sysconfig
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from html import escape
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from pydrake.geometry import Rgba
from pydrake.systems.framework import Context, Diagram

from drake_sot.diagrams.collision_log import collision_arrays, pair_log
from drake_sot.diagrams.pushes import pushes_record
from drake_sot.diagrams.run import RunResult
from drake_sot.diagrams.world import BuiltHumanoid
from drake_sot.errors import DrakeSotError
from drake_sot.systems.replay_view import FAR_COLOUR, NEAR_COLOUR, ArrowGroup, ForceArrows, PairLines
from drake_sot.systems.search import systems_of_type
from drake_sot.systems.self_collision import SelfCollisionAvoidance

#: The programs that render Graphviz source, in the order tried: ``graphviz-pure`` (a dependency,
#: pip-installed: the same SVG on every platform), then Graphviz's own ``dot``.
RENDERERS = ("graphviz-pure", "dot")

#: How to get a renderer, for the messages that say a picture was not rendered.
RENDERER_HINT = "pip install graphviz-pure, or apt-get install graphviz"


class GraphvizMissing(DrakeSotError, RuntimeError):
    """No Graphviz renderer (:data:`RENDERERS`) is installed: the picture was written as
    Graphviz source (``.dot``) instead.

    Attributes:
        source: the ``.dot`` file written in place of the picture.
    """

    def __init__(self, picture: Path, source: Path) -> None:
        super().__init__(f"no Graphviz renderer to draw {picture} ({RENDERER_HINT}): wrote {source}")
        self.source = source


#: What a writer raises when its file cannot be written: the file system's errors (ENOSPC
#: when the disk is full, EROFS, EACCES...), the Graphviz renderer failing, or no renderer
#: (which :meth:`Artefacts.write` takes as a picture left as source, not a failure).
WRITE_ERRORS: tuple[type[Exception], ...] = (OSError, subprocess.CalledProcessError, GraphvizMissing)


@dataclass
class Artefacts:
    """The files of a run, written one after the other by :meth:`write`: one that cannot be
    written (see :data:`WRITE_ERRORS`) is recorded in ``unwritten`` and the next is still
    attempted, so that a full disk costs the files that no longer fit and no others.

    A picture that no renderer could draw (:class:`GraphvizMissing`) is no failure: its Graphviz
    source takes its place in ``files`` and the picture is listed in ``unrendered``.

    Attributes:
        files: key (``npz``, ``png``...) → the file written.
        unwritten: the file (or files) that could not be written → why, in a few words.
        unrendered: the pictures written as Graphviz source instead, for want of a renderer.
    """

    files: dict[str, Path] = field(default_factory=dict)
    unwritten: dict[str, str] = field(default_factory=dict)
    unrendered: list[Path] = field(default_factory=list)

    def write(self, key: str, path: Path, writer: Callable[[Path], object]) -> None:
        """``writer(path)``; on success ``files[key] = path``, else ``unwritten[path]`` says why
        (or, for a picture without a renderer, ``files[key]`` is its source and ``unrendered``
        names it)."""
        try:
            writer(path)
        except GraphvizMissing as exc:
            self.files[key] = exc.source
            self.unrendered.append(path)
        except WRITE_ERRORS as exc:
            self.unwritten[str(path)] = _reason(exc)
        else:
            self.files[key] = path

    def write_several(self, what: str, writer: Callable[[], dict[str, Path]]) -> None:
        """``writer()``, which writes several files and returns them by key; on failure
        ``unwritten[what]`` says why (``what`` names the files, e.g. ``"out/walk_*.png"``)."""
        try:
            self.files.update(writer())
        except WRITE_ERRORS as exc:
            self.unwritten[what] = _reason(exc)


def report_unwritten(unwritten: Mapping[str, str]) -> None:
    """One line on stderr naming the files that could not be written (``Artefacts.unwritten``),
    and why; nothing when there are none."""
    if unwritten:
        files = "; ".join(f"{path} ({reason})" for path, reason in unwritten.items())
        print(f"could not write: {files}", file=sys.stderr)


def report_unrendered(unrendered: list[Path]) -> None:
    """One line on stderr naming the pictures written as Graphviz source for want of a renderer
    (``Artefacts.unrendered``), and how to get one; nothing when there are none."""
    if unrendered:
        pictures = ", ".join(str(path) for path in unrendered)
        print(
            f"not rendered, no Graphviz ({RENDERER_HINT}): {pictures}; wrote their .dot source",
            file=sys.stderr,
        )


def _reason(error: Exception) -> str:
    if isinstance(error, OSError) and error.strerror:
        return f"{error.strerror}, errno {errno.errorcode.get(error.errno, error.errno)}"
    if isinstance(error, subprocess.CalledProcessError):
        return f"{error.cmd[0]} exited with status {error.returncode}"
    return str(error)


def output_directory(path: str | Path) -> Path:
    """``path`` as a directory the artefacts can be written into: created (with its parents)
    when missing, then probed by creating and deleting a temporary file in it.

    Raises:
        OSError: naming ``path`` and the reason (an empty name, which would be the current
            directory; an existing file, a path under a file, no write permission, a read-only
            file system...).
    """
    if not str(path):
        raise FileNotFoundError("output directory '': empty; name a directory (e.g. 'out')")
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise NotADirectoryError(f"{str(out)!r} is a file, not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=out):
            pass
    except OSError as exc:
        raise type(exc)(f"cannot write into {str(out)!r}: {exc.strerror or exc}") from exc
    return out


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (hidden, same suffix, so writers that infer the format
    from the name still do) to write to; when the block ends without an exception it replaces
    ``path``, otherwise it is deleted."""
    path = Path(path)
    temporary = path.with_name(f".{path.stem}.{secrets.token_hex(4)}.partial{path.suffix}")
    try:
        yield temporary
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


def write_figure(figure: Figure, path: str | Path) -> None:
    """Save a matplotlib figure (format from the suffix of ``path``)."""
    with atomic_path(path) as temporary:
        figure.savefig(temporary)


def graphviz_renderer() -> str | None:
    """The first of :data:`RENDERERS` found in this interpreter's scripts directory (where pip
    installs ``graphviz-pure``, on PATH or not) or on PATH; None when there is none."""
    path = os.pathsep.join((sysconfig.get_path("scripts"), os.environ.get("PATH", os.defpath)))
    for name in RENDERERS:
        found = shutil.which(name, path=path)
        if found is not None:
            return found
    return None


def render_svg(source: str, path: str | Path) -> None:
    """Render Graphviz ``source`` to the SVG file ``path`` with :func:`graphviz_renderer`.

    Raises:
        GraphvizMissing: no renderer is installed; ``source`` was written beside ``path`` as
            ``.dot`` instead, so nothing is lost.
        subprocess.CalledProcessError: the renderer failed.
        OSError: ``path`` (or the ``.dot``) cannot be written.
    """
    path = Path(path)
    renderer = graphviz_renderer()
    if renderer is None:
        dot = path.with_suffix(".dot")
        with atomic_path(dot) as temporary:
            temporary.write_text(source, encoding="utf-8")
        raise GraphvizMissing(path, dot)
    with atomic_path(path) as temporary:
        subprocess.run([renderer, "-Tsvg", "-o", str(temporary)], input=source.encode(), check=True)


def write_svg(diagram: Diagram, path: str | Path, *, max_depth: int = 1) -> None:
    """Render Drake's own picture of ``diagram`` (``GetGraphvizString``: every system and
    port) to SVG; raises as :func:`render_svg`."""
    render_svg(diagram.GetGraphvizString(max_depth=max_depth), path)


def log_arrays(built: BuiltHumanoid, root_context: Context, result: RunResult) -> dict[str, np.ndarray]:
    """The run's logs as named arrays.

    Keys: ``time`` (T,) [s]; ``q`` (T, nq) and ``v`` (T, nv) of the simulated plant;
    ``q_ref`` (T, nq) the SoT's reference configuration (kinematic SoT only); ``error/<task>`` (T, m) each
    task's error (NaN while out of the stack); ``event_time`` and ``event_label``, the
    commands applied; ``pushes``, the diagram's pushes (a structured array, fields ``time``
    [s], ``body``, ``force`` (3,) [N, world frame], ``duration`` [s]; empty without pushes);
    ``fall`` (3,) [s, m, rad] the time, pelvis height and trunk tilt of the fall, when the
    robot fell. The extra logs of the builder follow their names (``fallen`` (T, 1) when a
    fall monitor watched, ``push_forces`` when there are pushes, ...); a self-collision task's
    rows, by name, are under ``collision/<task>/`` (:mod:`~drake_sot.diagrams.collision_log`).
    """
    state = built.loggers["state"].FindLog(root_context)
    time = state.sample_times()
    nq = built.plant.num_positions(built.info.model_instance)
    arrays: dict[str, np.ndarray] = {
        "time": time,
        "q": state.data()[:nq].T.copy(),
        "v": state.data()[nq:].T.copy(),
    }
    errors = _aligned(built.loggers["errors"].FindLog(root_context), time)
    for name, sl in built.error_slices().items():
        arrays[f"error/{name}"] = errors[:, sl]
    for name, logger in built.loggers.items():
        if name not in ("state", "errors"):
            arrays[name] = _aligned(logger.FindLog(root_context), time)
    if built.stack_history is not None:
        history = built.stack_history.history(root_context)
        arrays["stack_time"] = np.array([t for t, _ in history])
        arrays["stack"] = np.array([" > ".join(stack) for _, stack in history], dtype=str)
    arrays["event_time"] = np.array([t for t, _ in result.events])
    arrays["event_label"] = np.array([label for _, label in result.events], dtype=str)
    arrays["pushes"] = pushes_record(built.pushes)
    for task in built.tasks.values():
        if isinstance(task, SelfCollisionAvoidance) and pair_log(task.get_name()) in arrays:  # logged
            arrays.update(collision_arrays(task, arrays[pair_log(task.get_name())]))
    if result.fell is not None:
        arrays["fall"] = np.array([result.fell.time, result.fell.pelvis_height, result.fell.tilt])
    return arrays


def _aligned(log, time: np.ndarray) -> np.ndarray:
    """Samples of ``log`` at ``time`` (matched by time: a log trimmed to its window, or one with
    fewer samples, leaves NaN where it has none)."""
    times, data = log.sample_times(), log.data().T
    out = np.full((len(time), data.shape[1]), np.nan)
    index = np.minimum(np.searchsorted(times, time - 1e-9), len(times) - 1)
    if len(times):
        found = np.abs(times[index] - time) <= 1e-9
        out[found] = data[index[found]]
    return out


#: The longest array name [UTF-8 bytes] an npz holds: a zip member's name is at most 65,535
#: bytes, and numpy adds ``.npy``. Task names are far shorter (:data:`drake_sot.stack.MAX_TASK_NAME`).
MAX_ARRAY_NAME = 65_535 - len(".npy")


def write_npz(arrays: dict[str, np.ndarray], path: str | Path) -> None:
    """Save the arrays (compressed) to ``path`` (name it ``*.npz``); load back with ``np.load(path)``.

    Raises:
        OSError: ``path`` cannot be written, or an array's name is longer than the zip format
            holds (:data:`MAX_ARRAY_NAME`; checked before anything is written, naming its
            first characters), so that a run's other artefacts are still written.
    """
    for name in arrays:
        if len(name.encode("utf-8", "surrogatepass")) > MAX_ARRAY_NAME:
            raise OSError(
                f"{path}: array name {name[:40]!r}... has {len(name)} characters: an npz holds at most "
                f"{MAX_ARRAY_NAME} bytes"
            )
    with atomic_path(path) as temporary, open(temporary, "wb") as file:
        np.savez_compressed(file, **arrays)


def write_replay(built: BuiltHumanoid, path: str | Path, *, scenario: str) -> None:
    """Publish the Meshcat recording and save the standalone HTML page, titled with the
    ``scenario``'s name and the robot's, with a legend of the force arrows the diagram draws
    (:class:`~drake_sot.systems.replay_view.ForceArrows`: what each colour is, and its scale) and
    of the lines of its self-collision pairs (:class:`~drake_sot.systems.replay_view.PairLines`).

    Raises:
        ValueError: the diagram was built without Meshcat (nothing to replay).
        OSError: ``path`` cannot be written.
    """
    if built.visualizer is None or built.meshcat is None:
        raise ValueError("this diagram was built without Meshcat: nothing to replay")
    built.visualizer.StopRecording()
    built.visualizer.PublishRecording()
    html = built.meshcat.StaticHtml()
    title = replay_title(scenario, built.info.robot)
    html = html.replace("<title>Drake MeshCat</title>", f"<title>{escape(title)}</title>", 1)
    groups = [group for arrows in systems_of_type(built.diagram, ForceArrows) for group in arrows.groups]
    pairs = systems_of_type(built.diagram, PairLines)
    html = html.replace("</body>", _legend(title, groups, pairs) + "</body>", 1)
    with atomic_path(path) as temporary:
        temporary.write_text(html, encoding="utf-8")


def replay_title(scenario: str, robot: str) -> str:
    """The title of a replay's page: the scenario and the robot."""
    return f"{scenario} on {robot} (drake_sot replay)"


def _swatch(colour: Rgba) -> str:
    """``colour`` as CSS."""
    return f"rgb({colour.r() * 255:.0f}, {colour.g() * 255:.0f}, {colour.b() * 255:.0f})"


def _legend(title: str, groups: list[ArrowGroup], pairs: list[PairLines]) -> str:
    """The replay's legend: its title, then a line per kind of arrow (colour, label, scale;
    groups alike, e.g. the two wrists, share one) and one per self-collision task whose pairs
    are drawn (the colours from ``d_i`` to ``d_s``)."""
    lines = [f'<div style="font-weight: bold">{escape(title)}</div>']
    for group in groups:
        line = (
            f'<div><span style="color: {_swatch(group.rgba)}">&#9632;&#9472;&#9654;</span> '
            f"{escape(group.label)} ({group.newtons_per_metre:g} N per m)</div>"
        )
        if line not in lines:
            lines.append(line)
    for drawn in pairs:
        lines.append(
            f'<div><span style="color: {_swatch(FAR_COLOUR)}">&#9472;&#9472;</span>'
            f'<span style="color: {_swatch(NEAR_COLOUR)}">&#9472;&#9472;</span> '
            f"{escape(drawn.task)}: pairs of collision shapes closer than {drawn.d_i:g} m, between "
            f"their closest points (green at {drawn.d_i:g} m to red at the margin, {drawn.d_s:g} m)</div>"
        )
    style = (
        "position: fixed; left: 8px; bottom: 8px; padding: 6px 10px; background: rgba(255, 255, 255, 0.85); "
        "font: 13px sans-serif; border-radius: 4px; pointer-events: none"
    )
    return f'<div id="drake-sot-legend" style="{style}">{"".join(lines)}</div>\n'
