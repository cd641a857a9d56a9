"""The script interpreter: the build phase makes the paper's diagram, the run phase acts on
its context, and every refusal says why."""

import tempfile
from pathlib import Path

import numpy as np
import pytest
from pydrake.math import RigidTransform

from drake_sot.diagrams.script_session import (
    CLASSES,
    Phase,
    ScriptSession,
    SessionError,
    load_script,
    schedule,
)
from drake_sot.errors import UnknownNameError
from drake_sot.models import half_sitting_configuration, make_control_model
from drake_sot.script import Plug, ScriptError, parse_script, parse_value

REPO = Path(__file__).resolve().parents[2]
PAPER_SCRIPT = REPO / "examples" / "paper_III_B.sot"


def connections(diagram) -> set[tuple[str, str, str, str]]:
    """Every connection of a diagram as (source system, output port, target system, input port)."""
    out = set()
    for (target, in_index), (source, out_index) in diagram.connection_map().items():
        out.add(
            (
                source.get_name(),
                source.get_output_port(out_index).get_name(),
                target.get_name(),
                target.get_input_port(in_index).get_name(),
            )
        )
    return out


@pytest.fixture(scope="module")
def paper_session() -> ScriptSession:
    """The example script's build phase, built (nothing simulated)."""
    session = ScriptSession()
    program = load_script(PAPER_SCRIPT)
    schedule(session, program)
    return session


def test_every_plug_of_the_paper_script_is_a_connection_of_the_diagram(paper_session):
    built = paper_session.built
    wired = connections(built.diagram)
    plugs = [s.command for s in load_script(PAPER_SCRIPT).statements if isinstance(s.command, Plug)]
    assert len(plugs) == 8
    for plug in plugs:
        source = "dyn" if plug.source.entity == "dyn2" else plug.source.entity
        assert (source, plug.source.name, plug.target.entity, plug.target.name) in wired, plug
    # set featureComDes.errorIN [3](0,-0,0.64): a constant source; set featureCom.sdes featureComDes:
    # featureCom's s* is fed by what feeds featureComDes's value, that source.
    assert ("featureComDes.errorIN", "y0", "featureComDes", "errorIN") in wired
    assert ("featureComDes.errorIN", "y0", "featureCom", "sdes") in wired
    # taskCom.add featureCom, and every task into the solver.
    for task, feature in (("taskCom", "featureCom"), ("taskTwofeet", "featureTwofeet")):
        assert (feature, "feature", task, feature) in wired
        assert (task, "task", "sot", task) in wired


def test_the_paper_scripts_entities_are_the_systems_it_names(paper_session):
    session = paper_session
    com = session.system("featureCom")
    assert com.dimension == 2  # set featureCom.selec 110 on a FeatureGeneric of size 3 (dyn.com)
    assert session.system("featureComDes").dimension == 3
    assert session.system("dyn2") is session.system("dyn") is session.built.dyn
    assert session.system("sot") is session.built.sot
    assert set(session.built.sot.task_names) == {"taskCom", "taskTwofeet", "taskLeftFoot"}
    # dyn2.createOpPoint rleg 6 / lleg 12: the ankle-roll joints, as on HRP-2 (rank 0: the free flyer).
    plant, _ = make_control_model()
    ranked = sorted(
        (plant.get_joint(i) for i in plant.GetJointIndices() if plant.get_joint(i).num_positions() == 1),
        key=lambda j: j.position_start(),
    )
    assert ranked[5].name() == "r_ankle_roll" and ranked[11].name() == "l_ankle_roll"
    ops = session.built.dyn.operational_points
    assert ops["rleg"] == ranked[5].child_body().body_frame().name()
    assert ops["lleg"] == ranked[11].child_body().body_frame().name()


def test_get_writes_values_that_read_back(paper_session):
    session = paper_session
    plant, info = make_control_model()
    context = plant.CreateDefaultContext()
    plant.SetPositions(context, half_sitting_configuration(plant, info))
    com = parse_value(session.execute("get dyn.com")).array
    np.testing.assert_allclose(com, plant.CalcCenterOfMassPositionInWorld(context), atol=1e-12)
    # featureTwofeet holds where it started: its desired pose is the initial relative pose.
    X_l = plant.GetFrameByName("l_ankle_roll_link").CalcPoseInWorld(context)
    X_r = plant.GetFrameByName("r_ankle_roll_link").CalcPoseInWorld(context)
    desired = parse_value(session.execute("get featureTwofeet.position_des")).array
    np.testing.assert_allclose(desired, X_l.InvertAndCompose(X_r).GetAsMatrix4(), atol=1e-12)
    assert parse_value(session.execute("get taskCom.controlGain")) == 3.0
    assert session.execute("get featureCom.selec") == "110"


def test_the_paper_script_stands_and_moves_the_com_where_it_is_told():
    """Physics: the example script, then `set featureComDes.errorIN` at run time moves the CoM
    target 3 cm to the left; the robot stands, its feet stay, the CoM (measured on the
    simulated plant) reaches each target."""
    session = ScriptSession()
    session.run_script(PAPER_SCRIPT.read_text(), source=PAPER_SCRIPT.name)
    built = session.built
    context = session.simulator.get_context()
    plant_context = built.plant.GetMyContextFromRoot(context)

    def measured_com():
        return built.plant.CalcCenterOfMassPositionInWorld(plant_context, [built.info.model_instance])

    def sole(side):
        return built.frame_pose(context, f"{side}_foot")

    left0 = built.frame_pose(built.diagram.CreateDefaultContext(), "left_foot")  # where it starts
    assert context.get_time() == pytest.approx(2.5)
    assert session.execute("sot.list") == "taskLeftFoot taskTwofeet taskCom"
    assert np.linalg.norm(measured_com()[:2] - [0.0, 0.0]) < 0.005
    session.execute("set featureComDes.errorIN [3](0,0.03,0.64)")
    session.execute("run 2.0")
    com = measured_com()
    assert np.linalg.norm(com[:2] - [0.0, 0.03]) < 0.005
    pelvis = built.plant.GetPositions(plant_context, built.info.model_instance)[4:7]
    assert abs(pelvis[2] - built.q0[6]) < 0.02, "the robot fell or crouched"
    assert np.linalg.norm(sole("left").translation() - left0.translation()) < 0.005
    assert abs(sole("right").translation()[1] - sole("left").translation()[1] + 0.19) < 0.005


def test_a_build_time_command_after_the_build_says_why(paper_session):
    for line in (
        "new Task taskLate",
        "plug dyn.com featureCom.errorIN",
        "taskCom.add featureTwofeet",
        "set featureCom.selec 111",
        "destroy taskCom",
        "dyn.createOpPoint rh right_hand",
    ):
        with pytest.raises(SessionError) as caught:
            paper_session.execute(line)
        message = str(caught.value)
        assert message.startswith(
            f"{line}: the diagram is built (by paper_III_B.sot, line 54: sot.push taskLeftFoot)"
        )
        assert "build-time command" in message


def test_a_script_with_a_build_time_line_after_a_run_time_one_is_refused_before_it_runs(tmp_path):
    path = tmp_path / "late.sot"
    path.write_text("new FeatureCoM f\nnew Task t\nt.add f\nsot.push t\nrun 0.1\nnew Task t2\n")
    with pytest.raises(
        SessionError,
        match=r"late.sot, line 6: new Task t2: the diagram is built \(by late.sot, line 4: sot.push t\)",
    ):
        schedule(ScriptSession(), load_script(path))


def test_introspection_works_in_the_build_phase_and_builds_nothing():
    session = ScriptSession()
    assert (
        session.execute("pool.help")
        == "Pool:\n- list\n- listFeature\n- listTask\n- writegraph FileName\n- listClass\n- help"
    )
    session.execute("new FeatureCoM featureCom")
    session.execute("new Task taskCom")
    session.execute("taskCom.add featureCom")
    assert (
        session.execute("pool.list") == "pool (Pool)\ndyn (Dynamic)\nfeatureCom (FeatureCoM)\ntaskCom (Task)"
    )
    assert session.execute("pool.listFeature") == "featureCom"
    assert session.execute("pool.listTask") == "taskCom"
    assert session.execute("pool.listClass").splitlines()[0].startswith("FeatureGeneric: ")
    help_text = session.execute("featureCom.help")
    assert "inputs: com, Jcom, sdes, sdes_dot" in help_text and "outputs: feature, error" in help_text
    assert "add FEATURE" in session.execute("taskCom.help") and "[build]" in session.execute("taskCom.help")
    assert not session.is_built
    assert session.phase(parse_script("sot.push taskCom")[0].command) == Phase.RUN


def test_refusals_name_what_is_wrong():
    session = ScriptSession()
    session.run_script("new FeatureGeneric f\nnew Task t\nt.add f\nnew FeaturePoint6d p")
    cases = {
        "new Featurexyz g": f"unknown class 'Featurexyz'; known: {', '.join(sorted(CLASSES))}",
        "new Task t": "the name 't' is taken",
        "new Task device": "the name 'device' is taken",
        "new SOT a\nnew SOT b": "the diagram has one SOT, 'a', already",
        "plug dyn.nope f.errorIN": "'dyn' (Dynamic): unknown signal 'nope'; known: Jcom, com, inertia, q",
        "plug f.errorIN f.sdes": "f.errorIN is an input signal; an output signal is needed here",
        "plug dyn.com dyn.q": "dyn.q is fed by the build: the reference configuration",
        "plug zzz.com f.errorIN": "unknown entity 'zzz'; known: a, dyn, f, p, pool, t",  # a: the SOT above
        "t.add dyn": "'dyn' (Dynamic) is not a feature",
        "t.add f": "t has f already",
        "t.fly 3": "'t' (Task): unknown command 'fly'; known: add, controlGain, controlGainAdaptive, help",
        "t.controlGain -1": "gain = -1.0 1/s: must be finite and > 0",
        "set f.sdes t": "'t' (Task) is not a feature",
        "set f.errorIN featureX": "only a feature's desired value takes another feature's name",
        "set p.position_des [2,2]((1,0),(0,1))": "takes a [4,4] homogeneous matrix or a [3] position",
        "set p.position_des [4,4]((2,0,0,0),(0,1,0,0),(0,0,1,0),(0,0,0,1))": "is not a rigid transform",
        "destroy dyn": "'dyn' (Dynamic) cannot be destroyed",
        "dyn.createOpPoint x 99": "joint rank 99: must be 0 (the free flyer) to 30",
        "dyn.createOpPoint com 6": "dyn already has a signal 'com'",
        "run ../outside.sot": "resolves outside the script directory",
    }
    for text, expected in cases.items():
        lines = text.split("\n")
        for line in lines[:-1]:
            session.execute(line)
        with pytest.raises(SessionError) as caught:
            session.execute(lines[-1])
        assert expected in str(caught.value), (text, str(caught.value))
        assert str(caught.value).startswith(lines[-1] + ": ")
    assert not session.is_built


def test_an_unknown_name_raises_an_unknown_name_error_of_its_kind():
    session = ScriptSession()
    session.run_script("new FeatureGeneric f\nnew Task t")
    cases = {
        "plug zzz.com f.errorIN": ("entity", "zzz", {"pool", "dyn", "f", "t"}),
        "plug dyn.nope f.errorIN": ("signal", "nope", {"q", "com", "Jcom", "inertia"}),
        "t.fly 3": ("command", "fly", {"help", "add", "controlGain", "controlGainAdaptive"}),
        "new Featurexyz g": ("class", "Featurexyz", set(CLASSES)),
    }
    for text, (kind, name, known) in cases.items():
        with pytest.raises(UnknownNameError) as caught:
            session.execute(text)
        assert isinstance(caught.value, SessionError) and isinstance(caught.value, KeyError)
        assert (caught.value.kind, caught.value.name, caught.value.known) == (
            kind,
            name,
            tuple(sorted(known)),
        )
        assert str(caught.value).startswith(f"{text}: ") and str(caught.value).endswith(
            f"unknown {kind} {name!r}; known: {', '.join(sorted(known))}"
        )


def test_build_errors_name_the_entity_and_its_line():
    session = ScriptSession()
    session.run_script("new FeatureGeneric f\nnew Task t\nt.add f", source="s.sot")
    with pytest.raises(
        SessionError,
        match=r"building 'f' \(FeatureGeneric\) \(s.sot, line 1: new FeatureGeneric f\): "
        "f: its size comes from errorIN",
    ):
        session.execute("sot.push t")
    session = ScriptSession()
    session.run_script(
        "new FeaturePoint6d p\nset p.position_des [4,4]((1,0,0,0),(0,1,0,0),(0,0,1,0),(0,0,0,1))\n"
        "plug dyn.com p.position\nnew Task t\nt.add p",
        source="s.sot",
    )
    with pytest.raises(
        SessionError,
        match=r"plug dyn.com p.position: the output is a vector of size 3, the input takes an abstract value",
    ):
        session.execute("get p.error")


def test_run_time_values_change_only_what_the_build_left_settable(paper_session, tmp_path):
    session = paper_session
    context = session.built.create_simulator().get_mutable_context()  # another simulator's context
    session.execute("set featureComDes.errorIN [3](0.01,0.02,0.64)", context)
    assert parse_value(session.execute("get featureCom.sdes", context)).values == (0.01, 0.02, 0.64)
    with pytest.raises(
        SessionError, match="featureCom.sdes is set to the value of featureComDes .*change its source"
    ):
        session.execute("set featureCom.sdes [3](0,0,0.7)", context)
    with pytest.raises(SessionError, match="featureTwofeet.Jq is plugged from dyn.Jrleg"):
        session.execute("set featureTwofeet.Jq [1](0)", context)
    with pytest.raises(SessionError, match="taskCom.gain: nothing feeds this input; set it before the build"):
        session.execute("set taskCom.gain 2", context)
    with pytest.raises(SessionError, match="must have shape \\(3,\\)"):
        session.execute("set featureComDes.errorIN [2](0,0)", context)
    session.execute("taskCom.controlGain 7", context)
    assert session.execute("get taskCom.controlGain", context) == "7.0"
    session.execute("set featureLeftFoot.position_des [3](0,0.1,0)", context)
    X = parse_value(session.execute("get featureLeftFoot.position_des", context)).array
    assert np.allclose(X[:3, 3], (0.0, 0.1, 0.0)) and np.allclose(X[:3, :3], np.eye(3), atol=1e-12)
    with pytest.raises(SessionError, match="run DURATION advances the session's own simulator"):
        session.execute("run 0.1", context)
    with pytest.raises(SessionError, match="not a root context of this session's diagram"):
        other = ScriptSession()
        other.run_script("new FeatureCoM f\nnew Task t\nt.add f")
        session.execute("sot.list", other.simulator.get_context())


def test_sot_commands_act_on_the_context_given(paper_session):
    session = paper_session
    context = session.built.create_simulator().get_mutable_context()
    session.execute("sot.push taskLeftFoot", context)
    session.execute("sot.push taskCom", context)
    session.execute("sot.push taskTwofeet", context)
    session.execute("sot.up taskTwofeet", context)
    assert session.execute("sot.list", context) == "taskLeftFoot taskTwofeet taskCom"
    session.execute("sot.rm taskLeftFoot", context)
    assert session.execute("sot.pop", context) == "taskCom"
    assert session.built.sot.list(context) == ("taskTwofeet",)
    with pytest.raises(SessionError, match="unknown task 'taskX'; known: ") as caught:
        session.execute("sot.push taskX", context)
    assert isinstance(caught.value, UnknownNameError) and caught.value.kind == "task"
    assert caught.value.known == tuple(sorted(session.built.sot.task_names))
    assert {"taskTwofeet", "taskCom", "taskLeftFoot"} <= set(caught.value.known)
    session.execute("sot.clear", context)
    assert session.execute("sot.list", context) == ""


def test_writegraph_writes_inside_the_output_directory(tmp_path):
    session = ScriptSession(output_dir=tmp_path)
    session.run_script("new FeatureCoM f\nnew Task t\nt.add f")
    assert session.execute("pool.writegraph graph.dot") == f"wrote {tmp_path / 'graph.dot'}"
    text = (tmp_path / "graph.dot").read_text()
    assert text.startswith("digraph") and "taskCom" not in text
    assert 'id="f.feature->t.f"' in text  # the signal graph: the feature's plug into the task's
    assert session.execute("pool.writegraph graph.dot") == f"wrote {tmp_path / 'graph.dot'}"  # its own file


@pytest.mark.parametrize(
    "name", ["../graph.dot", "sub/graph.dot", "/tmp/x.dot", "..", ".", "a\\\\b.dot", "sub/../g.dot"]
)
def test_writegraph_takes_only_a_plain_file_name_and_creates_no_directory(tmp_path, name):
    out = tmp_path / "out"
    out.mkdir()
    session = ScriptSession(output_dir=out)
    session.run_script("new FeatureCoM f\nnew Task t\nt.add f")
    with pytest.raises(SessionError, match="must be a plain file name"):
        session.execute(f'pool.writegraph "{name}"')
    assert sorted(tmp_path.rglob("*")) == [out]  # nothing written, no directory made


def test_writegraph_never_replaces_a_file_it_did_not_write(tmp_path):
    (tmp_path / "served.sot").write_text("keep me")
    (tmp_path / "link.dot").symlink_to(tmp_path / "elsewhere.txt")  # dangling: exists as a link only
    session = ScriptSession(output_dir=tmp_path)
    session.run_script("new FeatureCoM f\nnew Task t\nt.add f")
    for name in ("served.sot", "link.dot"):
        with pytest.raises(SessionError, match=f"'{name}': .* exists and this session did not write it"):
            session.execute(f"pool.writegraph {name}")
    assert (tmp_path / "served.sot").read_text() == "keep me"
    assert not (tmp_path / "elsewhere.txt").exists()
    other = ScriptSession(output_dir=tmp_path)  # a file of another session is not this one's
    other.run_script("new FeatureCoM f\nnew Task t\nt.add f")
    session.execute("pool.writegraph mine.dot")
    with pytest.raises(SessionError, match="'mine.dot': .* this session did not write it"):
        other.execute("pool.writegraph mine.dot")


def test_without_an_output_directory_a_session_writes_into_a_fresh_one(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    temporary = tmp_path.parent / f"{tmp_path.name}_tmp"  # the temporary directories, not in the cwd
    temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(temporary))
    session = ScriptSession()
    session.run_script("new FeatureCoM f\nnew Task t\nt.add f")
    answer = session.execute("pool.writegraph graph.dot")
    written = Path(answer.removeprefix("wrote "))
    assert written.is_file() and written.parent == session.output_dir
    assert session.output_dir.resolve() != tmp_path.resolve() and list(tmp_path.iterdir()) == []
    assert session.output_dir.parent == temporary
    assert ScriptSession().output_dir != session.output_dir  # one directory per session


def test_run_file_plays_a_script_inside_the_script_directory(tmp_path):
    (tmp_path / "features.sot").write_text(
        "new FeatureCoM featureCom\nnew Task taskCom\ntaskCom.add featureCom\n"
    )
    (tmp_path / "main.sot").write_text("run features.sot\nsot.push taskCom\nrun 0.05\n")
    (tmp_path / "loop.sot").write_text("run loop.sot\n")
    (tmp_path / "bad.sot").write_text("new FeatureCoM\n")
    session = ScriptSession(script_dir=tmp_path)
    assert session.execute("run main.sot") == "t = 0.050 s"
    assert session.execute("sot.list") == "taskCom"
    with pytest.raises(SessionError, match="loop.sot runs itself: loop.sot -> loop.sot"):
        ScriptSession(script_dir=tmp_path).execute("run loop.sot")
    with pytest.raises(ScriptError, match="bad.sot, line 1, column 15: expected the new entity's name"):
        ScriptSession(script_dir=tmp_path).execute("run bad.sot")
    program = load_script(tmp_path / "main.sot")
    assert [s.where for s in program.statements] == [
        "features.sot, line 1",
        "features.sot, line 2",
        "features.sot, line 3",
        "main.sot, line 2",
        "main.sot, line 3",
    ]
    assert program.scripted_duration == 0.05


def test_every_class_declares_the_signals_its_system_has():
    """The names the script offers are the ports of the Drake systems (no drift)."""
    session = ScriptSession()
    session.run_script(
        "\n".join(
            [
                "dyn.createOpPoint rh right_hand",
                "dyn.createOpPoint lh left_hand",
                "new FeatureGeneric fg\nplug dyn.com fg.errorIN",
                "new FeatureCoM fc",
                "new FeaturePoint6d fp\nplug dyn.rh fp.position",
                "new FeaturePoint6dRelative fr\nplug dyn.rh fr.position\nplug dyn.lh fr.positionRef",
                "new FeaturePosture fq",
                "new FeatureJointLimits fj\nfj.margin 0.05",
                "new Task t\nt.add fc\nt.add fp",
                "new TaskSelfCollision tc",
                "new PatternGenerator pg",
                "new AdmittanceController adm\nadm.hand right\nadm.mass 4 0.2\nadm.damping 60 4",
                "new TaskSequencer seq\nseq.addState a\nseq.addState b",
                "seq.addTransition a b above in_process 0.5\nseq.addOutput on 0\nseq.addEntry b set on 1",
                "seq.addEntry b push t\nplug pg.in_process seq.in_process",
            ]
        )
    )
    session.build()
    for entity in session.entities():
        system = entity.system
        if system is None:
            continue
        inputs = {system.get_input_port(i).get_name() for i in range(system.num_input_ports())}
        outputs = {system.get_output_port(i).get_name() for i in range(system.num_output_ports())}
        assert set(entity.inputs()) == inputs, entity.name
        assert set(entity.outputs()) == outputs, entity.name
    assert set(CLASSES) == {
        "FeatureGeneric",
        "FeatureCoM",
        "FeaturePoint6d",
        "FeaturePoint6dRelative",
        "FeaturePosture",
        "FeatureJointLimits",
        "Task",
        "TaskSelfCollision",
        "SOT",
        "PatternGenerator",
        "AdmittanceController",
        "TaskSequencer",
    }


def test_pattern_generator_sequencer_and_admittance_act_at_run_time():
    """A sequencer drives the stack (the paper's DecisionServer): once the pattern generator walks
    (`pg.parsecmd :stepseq`), it pushes the hand task and raises the admittance's `active` flag."""
    session = ScriptSession()
    session.run_script(
        """
        new FeatureCoM featureCom
        new Task taskCom
        taskCom.add featureCom
        new PatternGenerator pg
        new AdmittanceController admRH
        admRH.hand right
        admRH.mass 4 0.2
        admRH.damping 60 4
        dyn.createOpPoint rhand right_hand
        new FeaturePoint6d featureRH
        plug dyn.rhand featureRH.position
        plug dyn.Jrhand featureRH.Jq
        plug admRH.position_des featureRH.position_des
        plug admRH.velocity_des featureRH.velocity_des
        new Task taskForce
        taskForce.add featureRH
        new TaskSequencer decision
        decision.addOutput force_active 0
        decision.addState standing
        decision.addState walking
        decision.initialStack taskCom
        decision.addTransition standing walking above in_process 0.5
        decision.addEntry walking push taskForce
        decision.addEntry walking set force_active 1
        plug pg.in_process decision.in_process
        plug decision.stack sot.stack
        plug decision.force_active admRH.active
        """
    )
    assert session.execute("decision.current") == "standing"
    assert session.execute("sot.list") == "taskCom"
    with pytest.raises(SessionError, match="cannot push taskForce: the stack comes from input port 'stack'"):
        session.execute("sot.push taskForce")
    session.execute("pg.parsecmd :stepseq 0.05 -0.19 0")
    session.execute("run 0.02")
    assert session.execute("get pg.in_process") == "[1](1.0)"
    assert session.execute("decision.current") == "walking"
    assert session.execute("sot.list") == "taskCom taskForce"
    assert session.execute("get admRH.fault") == "[1](0.0)"
    hand = session.built.frame_pose(session.simulator.get_context(), "right_hand")
    position_des = parse_value(session.execute("get admRH.position_des")).array
    assert np.linalg.norm(position_des[:3, 3] - hand.translation()) < 0.01
    with pytest.raises(
        SessionError,
        match=r"pg.parsecmd :stepheight 2: :stepheight: .*step_height = 2.0 m: must be in \[0.01, 0.3\] m",
    ):
        session.execute("pg.parsecmd :stepheight 2")
    with pytest.raises(SessionError, match="parsecmd starts with a :verb"):
        session.execute("pg.parsecmd stepheight 0.05")


def test_pose_values_are_rigid_transforms():
    session = ScriptSession()
    session.run_script(
        "dyn.createOpPoint rh right_hand\nnew FeaturePoint6d p\nplug dyn.rh p.position\nnew Task t\nt.add p"
    )
    session.build()
    c, s = np.cos(0.3), np.sin(0.3)
    session.execute(f"set p.position_des [4,4](({c},{-s},0,0.3),({s},{c},0,-0.2),(0,0,1,0.9),(0,0,0,1))")
    X = session.system("p").desired(session.simulator.get_context())
    assert isinstance(X, RigidTransform)
    np.testing.assert_allclose(
        X.GetAsMatrix4(), [[c, -s, 0, 0.3], [s, c, 0, -0.2], [0, 0, 1, 0.9], [0, 0, 0, 1]]
    )


def test_a_failed_build_says_so_to_every_later_run_time_command():
    session = ScriptSession()
    session.run_script("new FeatureGeneric f\nnew Task t\nt.add f")
    with pytest.raises(SessionError, match="its size comes from errorIN"):
        session.execute("sot.push t")
    with pytest.raises(SessionError, match=r"sot.list: the build failed \(building 'f'.*a diagram half made"):
        session.execute("sot.list")


def test_commands_made_in_python_are_checked_like_parsed_ones():
    """The parser reads finite numbers only; a command value built in Python is checked too."""
    from drake_sot.script import Call, Name, RunFor, Set, Signal, Vector

    session = ScriptSession()
    session.run_script("new FeatureGeneric g\nset g.errorIN [3](0,0,0)\nnew Task t\nt.add g")
    for command, expected in (
        (Set(Signal("g", "sdes"), Vector((0.0, float("nan"), 0.0))), r"contains NaN or Inf \(entry \[1\]\)"),
        (Call("t", "controlGain", (float("inf"),)), "the gain = inf: must be a finite number"),
        (Call("t", "add", (Name("nothing"),)), "unknown entity 'nothing'"),
    ):
        with pytest.raises(SessionError, match=expected):
            session.execute(command)
    session.execute("sot.push t")
    with pytest.raises(SessionError, match="run DURATION = nan s: must be finite and > 0"):
        session.execute(RunFor(float("nan")))


def test_the_walking_script_takes_the_steps_it_asks_for():
    """examples/walk_two_steps.sot: the pattern generator's references plugged into the feet,
    CoM and waist features; `:stepseq 0.15 -0.19 0 0.15 0.19 0` (each footprint in the frame
    of the other foot's) lands the right sole 15 cm ahead of the left one, then the left 15 cm
    ahead of that, on the simulated plant; the robot stays upright and stops."""
    script = REPO / "examples" / "walk_two_steps.sot"
    session = ScriptSession()
    session.run_script(script.read_text(), source=script.name)
    built = session.built
    context = session.simulator.get_context()
    assert ("pg", "load", "torque_feedforward", "load") in connections(built.diagram)
    assert session.execute("get pg.in_process") == "[1](0.0)"
    plant, info = make_control_model()
    start = plant.CreateDefaultContext()
    plant.SetPositions(start, half_sitting_configuration(plant, info))
    left0 = plant.GetFrameByName(info.frames["left_foot"]).CalcPoseInWorld(start).translation()
    right = built.frame_pose(context, "right_foot").translation()
    left = built.frame_pose(context, "left_foot").translation()
    np.testing.assert_allclose(right[:2], left0[:2] + [0.15, -0.19], atol=0.01)
    np.testing.assert_allclose(left[:2], left0[:2] + [0.30, 0.0], atol=0.01)
    assert abs(right[2]) < 0.002 and abs(left[2]) < 0.002  # both on the ground
    q = built.plant.GetPositions(built.plant.GetMyContextFromRoot(context), built.info.model_instance)
    assert abs(q[6] - built.q0[6]) < 0.02, "the pelvis dropped"


def test_selection_flags_with_a_leading_zero_must_be_quoted():
    session = ScriptSession()
    session.run_script(
        "dyn.createOpPoint w pelvis\nnew FeaturePoint6d f\nplug dyn.w f.position\nnew Task t\nt.add f\n"
        "set f.selec 000111"
    )
    with pytest.raises(SessionError, match=r"'111' must be 6 characters.*loses its leading zeros: quote it"):
        session.build()
    quoted = ScriptSession()
    quoted.run_script(
        "dyn.createOpPoint w pelvis\nnew FeaturePoint6d f\nplug dyn.w f.position\nnew Task t\nt.add f"
    )
    with pytest.raises(SessionError, match="f.selec takes 0/1 flags"):
        quoted.execute("set f.selec 012")
    quoted.execute('set f.selec "000111"')
    assert quoted.build().tasks["t"].dimension == 3


def test_a_script_can_plug_an_operational_point_as_one_value():
    """``plug dyn.rh_frame fp.frame`` feeds the pose and the Jacobian in one signal; the feature
    then holds the operational point's pose at q0, as with ``plug dyn.rh fp.position``."""
    session = ScriptSession()
    session.run_script(
        "dyn.createOpPoint rh right_hand\nnew FeaturePoint6d fp\nplug dyn.rh_frame fp.frame\n"
        "new FeaturePoint6d fq\nplug dyn.rh fq.position\nplug dyn.Jrh fq.Jq\nnew Task t\nt.add fp\nt.add fq"
    )
    session.build()
    context = session.simulator.get_context()
    one, two = session.system("fp"), session.system("fq")
    a = one.GetOutputPort("feature").Eval(one.GetMyContextFromRoot(context))
    b = two.GetOutputPort("feature").Eval(two.GetMyContextFromRoot(context))
    np.testing.assert_allclose(a.error, 0.0, atol=1e-12)
    np.testing.assert_array_equal(a.jacobian, b.jacobian)
    np.testing.assert_array_equal(one.desired(context).GetAsMatrix4(), two.desired(context).GetAsMatrix4())
    with pytest.raises(SessionError, match=r"dyn already has a signal 'rh_frame'"):
        ScriptSession().run_script("dyn.createOpPoint rh right_hand\ndyn.createOpPoint rh_frame left_hand")


def test_the_solvers_outputs_plug_into_other_entities():
    """`plug sot.errors decision.errors`: a sequencer's guard on the solver's task errors. The CoM
    error decays as e0·exp(-λt) (ė* = -λe, Mansard et al. 2009, eq. 3): with λ = 5 1/s and
    e0 = 3 cm it crosses 2 mm at ln(15)/5 = 0.54 s, which is when the guard fires."""
    session = ScriptSession()
    session.run_script(
        """
        new FeatureCoM featureCom
        set featureCom.selec 110
        new Task taskCom
        taskCom.add featureCom
        taskCom.controlGain 5
        new TaskSequencer decision
        decision.addOutput reached 0
        decision.addState settling
        decision.addState moving
        decision.addState arrived
        decision.initialStack taskCom
        decision.addTransition settling moving timeout 0.02
        decision.addTransition moving arrived below errors 0.002 2
        decision.addEntry arrived set reached 1
        plug sot.errors decision.errors
        plug decision.stack sot.stack
        """
    )
    com0 = parse_value(session.execute("get dyn.com")).array
    session.execute(f"set featureCom.sdes [3]({com0[0] + 0.03},{com0[1]},{com0[2]})")
    crossing = np.log(0.03 / 0.002) / 5.0
    session.execute(f"run {crossing - 0.1:.3f}")
    assert session.execute("decision.current") == "moving"
    session.execute("run 0.2")
    assert session.execute("decision.current") == "arrived"
    assert session.execute("get decision.reached") == "[1](1.0)"
    error = parse_value(session.execute("get featureCom.error")).array
    assert np.linalg.norm(error) < 0.002


def test_a_solver_output_plugged_into_an_input_of_another_size_fails_at_the_build_naming_it():
    session = ScriptSession()
    session.run_script("new FeatureCoM f\nnew Task t\nt.add f\nplug sot.qdot f.sdes", source="s.sot")
    with pytest.raises(SessionError, match=r"s.sot, line 4: plug sot.qdot f.sdes"):
        session.execute("sot.push t")
    other = ScriptSession()
    other.run_script("new FeatureGeneric g\nplug sot.errors g.errorIN\nnew Task t\nt.add g")
    with pytest.raises(SessionError, match="sot.errors: its size is known only once the diagram is built"):
        other.execute("sot.push t")


def test_a_script_blends_stack_changes_over_a_given_time():
    """`decision.transitionTime 0.5` with `plug decision.smooth_stack sot.stack`: the sequencer's stack
    carries the change in progress; a bad time on a solver command is refused before it acts."""
    session = ScriptSession()
    session.run_script(
        """
        new FeatureCoM featureCom
        new Task taskCom
        taskCom.add featureCom
        new TaskSequencer decision
        decision.transitionTime 0.5
        decision.addState a
        decision.addState b
        decision.addEntry b push taskCom
        decision.addTransition a b timeout 0.1
        plug decision.smooth_stack sot.stack
        """
    )
    session.execute("run 0.2")
    assert session.execute("decision.current") == "b"
    assert session.execute("sot.list") == "taskCom"
    sequencer = session.entity("decision").system
    assert sequencer.machine.transition_time("b") == 0.5
    smooth = sequencer.GetOutputPort("smooth_stack").Eval(
        sequencer.GetMyContextFromRoot(session.simulator.get_context())
    )
    assert smooth.transition is not None and smooth.transition.duration == 0.5
    with pytest.raises(
        SessionError, match=r"^sot.clear -1: clear: transition = -1 s: must be in \[0, 60\] s$"
    ):
        session.execute("sot.clear -1")


def test_solver_commands_take_an_optional_transition_time():
    session = ScriptSession()
    session.run_script("new FeatureCoM featureCom\nnew Task taskCom\ntaskCom.add featureCom")
    session.execute("sot.push taskCom 0.5")  # this dialect's time; the paper's syntax stays valid
    sot = session.entity("sot").system
    stack = sot.GetOutputPort("stack").Eval(sot.GetMyContextFromRoot(session.simulator.get_context()))
    assert stack == ("taskCom",)
    held = sot.GetMyContextFromRoot(session.simulator.get_context()).get_abstract_state(0).get_value()
    assert held.transition is not None and held.transition.duration == 0.5
    session.execute("sot.rm taskCom")
    assert session.execute("sot.list") == ""
