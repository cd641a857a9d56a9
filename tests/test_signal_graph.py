"""The signal graph (``writegraph``) as the paper's Fig. 1: entities under their names, plugs named
after the ports, loggers and plumbing left out, one A4 page wide for the case study."""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import xml.etree.ElementTree as ET

import pytest
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, Multiplexer, VectorLogSink

from drake_sot import systems
from drake_sot.app import cli
from drake_sot.diagrams.scenario import build_scenario
from drake_sot.diagrams.signal_graph import FAMILIES, OBSERVERS, signal_graph, write_graph
from drake_sot.systems.leaf import SotLeafSystem

SVG = "{http://www.w3.org/2000/svg}"
#: An A4 page is 595 pt wide; the picture, scaled to fit it, keeps its 9-pt text readable down to
#: about half size: 1200 pt.
A4_READABLE_WIDTH = 1200.0


def _svg(path):
    root = ET.parse(path).getroot()
    width = float(re.fullmatch(r"([\d.]+)pt", root.get("width")).group(1))
    texts = {t.text for t in root.iter(f"{SVG}text")}
    edges = {g.get("id"): g for g in root.iter(f"{SVG}g") if g.get("class") == "edge"}
    nodes = {g.get("id") for g in root.iter(f"{SVG}g") if g.get("class") == "node"}
    return width, texts, edges, nodes


@pytest.fixture(scope="module")
def case_study():
    return build_scenario(cli.SCENARIOS["walk_then_interact"], None).built.diagram


def test_the_case_study_fits_a_page_and_names_the_papers_entities_and_their_signals(case_study, tmp_path):
    path = tmp_path / "walk_then_interact.svg"
    write_graph(case_study, path)
    width, texts, edges, nodes = _svg(path)
    assert width <= A4_READABLE_WIDTH
    # The SoT's names: the CoM's feature of taskCom is featureCom (Mansard et al. 2009).
    entities = {"sot", "dyn", "pg", "stabilizer", "taskCom", "featureCom", "device"}
    assert entities <= nodes and entities <= texts
    # Every connection between them, read from Drake's own connection map, is an edge of the
    # picture, and its two plugs are named in it.
    between = set()
    for (destination, i), (source, o) in case_study.connection_map().items():
        if {source.get_name(), destination.get_name()} <= entities:
            output, input_ = source.get_output_port(o).get_name(), destination.get_input_port(i).get_name()
            between.add(f"{source.get_name()}.{output}->{destination.get_name()}.{input_}")
            assert {output, input_} <= texts
    assert {
        "dyn.com->featureCom.com",
        "dyn.Jcom->featureCom.Jcom",
        "pg.com->stabilizer.com_ref",
        "stabilizer.com->featureCom.sdes",
        "featureCom.feature->taskCom.featureCom",
        "taskCom.task->sot.taskCom",
        "sot.qdot->device.qdot",
    } <= between
    assert between <= set(edges)


def test_loggers_and_plumbing_are_left_out_unless_everything_is_asked(case_study):
    drawn = signal_graph(case_study)
    everything = signal_graph(case_study, everything=True)
    for hidden in ("log_state", "scene_graph", "stack_history"):
        assert f'id="{hidden}"' not in drawn and f'id="{hidden}"' in everything
    assert 'id="plant"' in drawn  # the robot itself


class _Source(LeafSystem):
    def __init__(self):
        super().__init__()
        self.set_name("source")
        self.DeclareVectorOutputPort("y", 1, lambda context, out: out.SetAtIndex(0, 1.0))


class _Sink(LeafSystem):
    def __init__(self):
        super().__init__()
        self.set_name("sink")
        self.DeclareVectorInputPort("u", BasicVector(2))


def test_a_signal_through_plumbing_is_drawn_dashed_from_entity_to_entity(tmp_path):
    """source.y and a constant, multiplexed into sink.u: one dashed edge source.y -> sink.u, no
    multiplexer, no constant, no logger."""
    builder = DiagramBuilder()
    source, sink = builder.AddSystem(_Source()), builder.AddSystem(_Sink())
    mux = builder.AddSystem(Multiplexer([1, 1]))
    constant = builder.AddSystem(ConstantVectorSource([0.0]))
    logger = builder.AddSystem(VectorLogSink(1))
    builder.Connect(source.get_output_port(), mux.get_input_port(0))
    builder.Connect(constant.get_output_port(), mux.get_input_port(1))
    builder.Connect(mux.get_output_port(), sink.get_input_port())
    builder.Connect(source.get_output_port(), logger.get_input_port())
    diagram = builder.Build()
    path = tmp_path / "graph.svg"
    write_graph(diagram, path)
    _, texts, edges, nodes = _svg(path)
    assert nodes == {"source", "sink"}
    assert set(edges) == {"source.y->sink.u"}
    (line,) = [p for p in edges["source.y->sink.u"].iter(f"{SVG}path")]
    assert line.get("stroke-dasharray")  # dashed: through plumbing
    assert {"y", "u"} <= texts


def test_every_module_of_systems_is_a_family_or_an_observer():
    """A module of ``drake_sot.systems`` with a LeafSystem of its own is drawn in a family of the
    paper's (the self-collision avoidance among the tasks) or left out as an observer, never
    filed under "other" for want of a line in FAMILIES."""
    unplaced = []
    for module in pkgutil.iter_modules(systems.__path__):
        members = vars(importlib.import_module(f"{systems.__name__}.{module.name}")).values()
        if (
            any(
                inspect.isclass(c)
                and issubclass(c, LeafSystem)
                and c is not SotLeafSystem  # the base of them all, no system of its own
                and c.__module__.endswith(f".{module.name}")
                for c in members
            )
            and module.name not in FAMILIES.keys() | OBSERVERS
        ):
            unplaced.append(module.name)
    assert not unplaced
    assert FAMILIES["self_collision"] == "tasks"
