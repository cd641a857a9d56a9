"""The signal graph of a diagram as the Stack of Tasks' ``pool.writegraph`` drew it (Mansard et
al. 2009, Fig. 1): the entities (the dynamic model ``dyn``, the features, the tasks, the solver
``sot``, the pattern generator ``pg``, the admittance controllers, the sequencer, the command
server, the device and the robot) under their names, grouped by family, the signals flowing left
to right between plugs named after the ports.

Loggers, visualisers and Drake's plumbing (the scene graph, Meshcat, multiplexers, constant
sources...) are left out; a signal that goes through plumbing from one entity to another is drawn
dashed, straight from the one to the other. ``everything=True`` draws every system instead.
Drake's own picture, every system and port (``Diagram.GetGraphvizString``), is
:func:`~drake_sot.diagrams.artifacts.write_svg`.
"""

from __future__ import annotations

import html
from collections import defaultdict
from pathlib import Path

from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Diagram, System

from drake_sot.diagrams.artifacts import atomic_path, render_svg

#: The family of each module of ``drake_sot.systems`` whose systems are entities, as the
#: picture's groups name it; the systems of a module not listed (a user's own) are "other".
FAMILIES: dict[str, str] = {
    "kinematics": "dynamic model",
    "features": "features",
    "task": "tasks",
    "inequalities": "tasks",
    "self_collision": "tasks",
    "sot": "solver",
    "generalized_controller": "solver",
    "pattern_generator": "pattern generator",
    "stabilizer": "pattern generator",
    "zmp": "pattern generator",
    "random_steps": "pattern generator",
    "hand_steps": "pattern generator",
    "hip_strategy": "pattern generator",
    "stance_anchor": "pattern generator",
    "moving_point": "pattern generator",
    "admittance": "interaction",
    "force_sensor": "interaction",
    "partner": "interaction",
    "master": "interaction",
    "telecoop": "interaction",
    "channel": "interaction",
    "remote_link": "interaction",
    "sequencer": "decision",
    "priority_schedule": "decision",
    "command_server": "decision",
    "device": "robot",
    "feedforward": "robot",
}

#: The modules of ``drake_sot.systems`` whose systems only watch or draw (left out, as Drake's
#: systems are but the plant, the robot itself).
OBSERVERS = frozenset({"marker", "replay_view", "stack_history", "fall_monitor"})

#: Points of the picture's text: readable on an A4 page when the picture fits its width.
FONT_SIZE = 9

_PACKAGE = "drake_sot.systems."


def family(system: System) -> str | None:
    """The family ``system`` is drawn in (see :data:`FAMILIES`); None when it is left out of
    the picture (a logger, a visualiser, Drake's plumbing)."""
    if isinstance(system, MultibodyPlant):
        return "robot"
    module = type(system).__module__
    if module.startswith("pydrake."):
        return None
    name = module.removeprefix(_PACKAGE) if module.startswith(_PACKAGE) else None
    if name in OBSERVERS:
        return None
    return FAMILIES.get(name, "other") if name is not None else "other"


def signal_graph(diagram: Diagram, *, everything: bool = False) -> str:
    """The Graphviz source of the signal graph of ``diagram``'s top-level systems: each entity a
    box under its name, with the plugs that carry a drawn signal (inputs on the left, outputs on
    the right), inside its family's group; each signal an edge from plug to plug, whose SVG id
    is ``source.port->destination.port``. ``everything``: every system, plumbing included."""
    connections = diagram.connection_map()
    systems = diagram.GetSystems()
    shown = [s for s in systems if everything or family(s) is not None]
    shown_ids = {id(s) for s in shown}
    edges: set[tuple[System, int, System, int, bool]] = set()
    for (destination, input_index), (source, output_index) in connections.items():
        if id(destination) not in shown_ids:
            continue
        if id(source) in shown_ids:
            edges.add((source, int(output_index), destination, int(input_index), False))
            continue
        for origin, origin_index in _through_plumbing(connections, source, shown_ids, set()):
            if origin is not destination:
                edges.add((origin, origin_index, destination, int(input_index), True))
    inputs: dict[int, set[int]] = defaultdict(set)
    outputs: dict[int, set[int]] = defaultdict(set)
    for source, output_index, destination, input_index, _ in edges:
        outputs[id(source)].add(output_index)
        inputs[id(destination)].add(input_index)
    groups: dict[str, list[System]] = defaultdict(list)
    for system in shown:
        groups[family(system) or "plumbing"].append(system)
    lines = [
        "digraph signals {",
        "rankdir=LR; ranksep=0.18; nodesep=0.05;",
        f'graph [fontsize={FONT_SIZE}, fontname="Helvetica"];',
        f'node [shape=plain, fontsize={FONT_SIZE}, fontname="Helvetica"];',
        "edge [arrowsize=0.5, penwidth=0.7];",
    ]
    for number, (name, members) in enumerate(sorted(groups.items())):
        lines.append(f'subgraph cluster_{number} {{ label="{name}"; style=rounded; color=gray60;')
        for system in members:
            lines.append(_node(system, sorted(inputs[id(system)]), sorted(outputs[id(system)])))
        lines.append("}")
    for source, output_index, destination, input_index, indirect in sorted(edges, key=_edge_key):
        signal = (
            f"{source.get_name()}.{source.get_output_port(output_index).get_name()}->"
            f"{destination.get_name()}.{destination.get_input_port(input_index).get_name()}"
        )
        style = ", style=dashed" if indirect else ""
        if family(source) == "robot":
            style += ", constraint=false"  # the loop closes through the robot, drawn last
        lines.append(
            f"{_quoted(source.get_name())}:o{output_index}:e -> "
            f"{_quoted(destination.get_name())}:i{input_index}:w [id={_quoted(signal)}{style}];"
        )
    lines.append("}")
    return "\n".join(lines) + "\n"


def write_graph(diagram: Diagram, path: str | Path, *, everything: bool = False) -> None:
    """Write the signal graph of ``diagram`` (:func:`signal_graph`) to ``path``: rendered to SVG
    when ``path`` ends in ``.svg``, else as Graphviz source. Written atomically.

    Raises:
        ~drake_sot.diagrams.artifacts.GraphvizMissing: an SVG was asked and no Graphviz renderer
            is installed (the source was written beside ``path`` as ``.dot`` instead).
        subprocess.CalledProcessError: the renderer failed.
        OSError: the file cannot be written.
    """
    source = signal_graph(diagram, everything=everything)
    path = Path(path)
    if path.suffix == ".svg":
        render_svg(source, path)
        return
    with atomic_path(path) as temporary:
        temporary.write_text(source, encoding="utf-8")


def _through_plumbing(
    connections: dict, system: System, shown_ids: set[int], seen: set[int]
) -> list[tuple[System, int]]:
    """The outputs of drawn systems that feed the left-out ``system``, through any number of
    left-out systems (a multiplexer, the scene graph); ``seen`` breaks the loops."""
    seen.add(id(system))
    found: list[tuple[System, int]] = []
    for (destination, _), (source, output_index) in connections.items():
        if destination is not system:
            continue
        if id(source) in shown_ids:
            found.append((source, int(output_index)))
        elif id(source) not in seen:
            found += _through_plumbing(connections, source, shown_ids, seen)
    return found


def _node(system: System, inputs: list[int], outputs: list[int]) -> str:
    """An HTML-like label: the system's name over its drawn inputs (ports ``i<index>``) and
    outputs (``o<index>``), side by side."""
    rows = [f'<TR><TD COLSPAN="2"><B>{html.escape(system.get_name())}</B></TD></TR>']
    for row in range(max(len(inputs), len(outputs))):
        cells = []
        for ports, prefix, port_of, align in (
            (inputs, "i", system.get_input_port, "LEFT"),
            (outputs, "o", system.get_output_port, "RIGHT"),
        ):
            if row < len(ports):
                name = html.escape(port_of(ports[row]).get_name())
                cells.append(f'<TD PORT="{prefix}{ports[row]}" ALIGN="{align}">{name}</TD>')
            else:
                cells.append("<TD></TD>")
        rows.append(f"<TR>{''.join(cells)}</TR>")
    table = '<TABLE BORDER="1" CELLBORDER="0" CELLSPACING="0" CELLPADDING="1">' + "".join(rows) + "</TABLE>"
    return f"{_quoted(system.get_name())} [id={_quoted(system.get_name())}, label=<{table}>];"


def _quoted(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _edge_key(edge: tuple[System, int, System, int, bool]) -> tuple[str, int, str, int]:
    source, output_index, destination, input_index, _ = edge
    return source.get_name(), output_index, destination.get_name(), input_index
