"""Write what a run produced: the replay (HTML), the diagram (SVG), the logs (NPZ)."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import numpy as np
from pydrake.systems.framework import Context, Diagram

from drake_sot.diagrams.run import RunResult
from drake_sot.diagrams.world import BuiltHumanoid


def write_svg(diagram: Diagram, path: str | Path, *, max_depth: int = 1) -> None:
    """Render ``diagram.GetGraphvizString`` to SVG with Graphviz's ``dot``.

    Raises RuntimeError saying what to install when ``dot`` is missing (the ``.dot``
    source is written beside the SVG path first, so nothing is lost).
    """
    path = Path(path)
    source = diagram.GetGraphvizString(max_depth=max_depth)
    dot = shutil.which("dot")
    if dot is None:
        path.with_suffix(".dot").write_text(source)
        raise RuntimeError(
            f"Graphviz 'dot' not found: wrote {path.with_suffix('.dot')} instead of {path}; "
            "install it with 'apt-get install graphviz'"
        )
    subprocess.run([dot, "-Tsvg", "-o", str(path)], input=source.encode(), check=True)


def log_arrays(built: BuiltHumanoid, root_context: Context, result: RunResult) -> dict[str, np.ndarray]:
    """The run's logs as named arrays.

    Keys: ``time`` (T,) [s]; ``q`` (T, nq) and ``v`` (T, nv) of the simulated plant;
    ``q_ref`` (T, nq) the SoT's reference configuration (kinematic SoT only); ``error/<task>`` (T, m) each
    task's error (NaN while out of the stack); ``event_time`` and ``event_label``, the
    commands applied.
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
    return arrays


def _aligned(log, time: np.ndarray) -> np.ndarray:
    """Samples of ``log`` at ``time`` (the loggers share one period; guard against a length mismatch)."""
    data = log.data().T
    n = min(len(time), data.shape[0])
    out = np.full((len(time), data.shape[1]), np.nan)
    out[:n] = data[:n]
    return out


def write_npz(arrays: dict[str, np.ndarray], path: str | Path) -> None:
    """Save the arrays (compressed); load back with ``np.load(path)``."""
    np.savez_compressed(path, **arrays)


def write_replay(built: BuiltHumanoid, path: str | Path) -> None:
    """Publish the Meshcat recording and save the standalone HTML page."""
    if built.visualizer is None or built.meshcat is None:
        raise ValueError("this diagram was built without Meshcat: nothing to replay")
    built.visualizer.StopRecording()
    built.visualizer.PublishRecording()
    Path(path).write_text(built.meshcat.StaticHtml())
