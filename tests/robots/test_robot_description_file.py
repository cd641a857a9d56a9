"""Your own robot, without simulating it: the description file (TOML) read into a RobotDescription, its
refusals (each naming the file, the key and the value), a fuzz of its reader (hypothesis), the
draft of a description from a URDF, and ``--robot PATH`` on the command line."""

from __future__ import annotations

import importlib.util
import json
import math
import shutil
import tomllib
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from robot_data import assert_mutated_model_is_drafted_or_refused

from drake_sot.app import cli
from drake_sot.parameters import Parameter
from drake_sot.robots import RobotFileError, RobotFileMissing, get_robot
from drake_sot.robots.description import FORCE_SENSORS, LOGICAL_FRAMES, RobotDescription
from drake_sot.robots.description_file import RobotDescriptionError, load_description
from drake_sot.robots.draft import draft_description

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "robot"
#: The embedded humanoid's dimensions, as its module documents them: the sole plane 0.105 m
#: under the ankle axes, the foot link 0.03 m under them (on the force sensor), soles 23 x 13 cm.
SOLE_BELOW_FOOT_LINK = 0.105 - 0.03
SOLE = (0.23, 0.13)


@pytest.fixture
def robot_dir(tmp_path: Path) -> Path:
    """A copy of the shipped robot (URDF and description) in a directory of its own."""
    for name in ("humanoid.urdf", "humanoid.toml"):
        shutil.copy(EXAMPLE / name, tmp_path / name)
    return tmp_path


def toml(value, top: bool = True) -> str:
    """``value`` (what tomllib returns) as TOML text: a document of inline values; NaN and ±inf
    as TOML writes them, integers of any length as digits."""
    if top:
        return "".join(f"{json.dumps(k)} = {toml(v, False)}\n" for k, v in value.items())
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {toml(v, False)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(toml(v, False) for v in value) + "]"
    return json.dumps(value)


def shipped() -> dict:
    return tomllib.loads((EXAMPLE / "humanoid.toml").read_text())


def test_the_shipped_description_is_the_embedded_robot_read_from_files():
    robot = load_description(EXAMPLE / "humanoid.toml")
    embedded = get_robot("embedded")
    assert robot.model_file == EXAMPLE / "humanoid.urdf"
    assert dict(robot.drives) == dict(embedded.drives)  # gains by pattern, efforts from the URDF
    assert dict(robot.joint_limits) == dict(embedded.joint_limits)
    assert dict(robot.half_sitting) == dict(embedded.half_sitting)
    assert robot.sole_size == SOLE
    assert robot.frames["left_foot"].xyz == (0.0, 0.0, -SOLE_BELOW_FOOT_LINK)
    assert robot.step_timing == embedded.step_timing


def test_the_shipped_models_are_what_their_script_writes_from_the_embedded_tables():
    """The shipped models (URDF, SDF, MJCF) and the descriptions of the SDF and MJCF are not
    edited by hand: they are what ``make_models.py`` writes today."""
    spec = importlib.util.spec_from_file_location("make_models", EXAMPLE / "make_models.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    assert script.urdf_text() == (EXAMPLE / "humanoid.urdf").read_text()
    assert script.sdf_text() == (EXAMPLE / "humanoid.sdf").read_text()
    assert script.mjcf_text() == (EXAMPLE / "humanoid.xml").read_text()
    assert script.description_text("sdf", "humanoid.sdf") == (EXAMPLE / "humanoid_sdf.toml").read_text()
    assert script.description_text("mjcf", "humanoid.xml") == (EXAMPLE / "humanoid_mjcf.toml").read_text()


def test_a_path_is_a_robot_wherever_a_name_is(robot_dir, monkeypatch):
    """The model path relative to the description file, whatever the working directory; the
    model's path stands for the description beside it; the robot parameter takes both."""
    monkeypatch.chdir(robot_dir.parent)
    by_toml = get_robot(str(robot_dir / "humanoid.toml"))
    assert by_toml.model_file == (robot_dir / "humanoid.urdf").resolve()
    assert get_robot(str(robot_dir / "humanoid.urdf")) == by_toml
    monkeypatch.chdir(robot_dir)
    assert get_robot("humanoid.toml").name == "humanoid-urdf"
    from drake_sot.diagrams.scenario import ROBOT

    assert ROBOT.check("humanoid.toml") == "humanoid.toml"
    with pytest.raises(ValueError, match="or a path ending with .toml"):
        ROBOT.check("humanoid.yaml")


def test_a_model_without_a_description_beside_it_says_how_to_draft_one(tmp_path):
    shutil.copy(EXAMPLE / "humanoid.urdf", tmp_path / "robot.urdf")
    with pytest.raises(RobotFileMissing, match=r"drake-sot robot draft .*robot\.urdf > .*robot\.toml"):
        get_robot(str(tmp_path / "robot.urdf"))


def test_an_edited_file_is_read_again(robot_dir):
    path = robot_dir / "humanoid.toml"
    assert load_description(path).contact_radius == 0.01
    path.write_text(path.read_text().replace("contact_radius = 0.01", "contact_radius = 0.012"))
    assert load_description(path).contact_radius == 0.012


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda d: d.pop("base_body"), "base_body is missing"),
        (lambda d: d["frames"].pop("left_hand"), "frames.left_hand is missing"),
        (lambda d: d.update(sole_size=[0.23, math.nan]), r"sole_size\[1\] = nan: must be a number"),
        (lambda d: d.update(contact_radius=math.inf), "contact_radius = inf"),
        (lambda d: d.update(contact_radius=10**30), "contact_radius = 1000000000000000000000000000000"),
        (lambda d: d.update(sole_size="big"), "sole_size = 'big': must be an array of 2 numbers"),
        (lambda d: d["half_sitting"].update(r_knee=3.0), r"half_sitting.r_knee = 3.0: .*\[0, 2.618\]"),
        (lambda d: d["half_sitting"].update(no_joint=0.1), "half_sitting: unknown key 'no_joint'"),
        (lambda d: d["drives"].pop("knee"), r"no pattern matches joints \['r_knee', 'l_knee'\]"),
        (
            lambda d: d["drives"].update({"(": {"kp": 1.0, "kd": 0.0}}),
            "drives key = '\\(': must be a regular",
        ),
        (
            lambda d: d["drives"]["knee"].update(kp=-1.0),
            r"drives.'knee'.kp = -1.0: must be a number \(finite, > 0\)",
        ),
        (
            lambda d: d.update(model="robot.obj"),
            r"model = .*robot.obj.*: must be a model file ending with .urdf, .sdf, .xml \(MJCF\)",
        ),
        (lambda d: d.update(model="absent.urdf"), "absent.urdf.* does not exist"),
        (lambda d: d["collision"][0].update(kind="cone"), r"collision\[0\].kind = 'cone'"),
        (lambda d: d["step_timing"].update(single_support=True), "step_timing.single_support = True"),
        (lambda d: d.update(colour="red"), "unknown key 'colour'"),
    ],
)
def test_a_wrong_key_or_value_is_named_with_the_file(robot_dir, edit, message):
    data = shipped()
    edit(data)
    path = robot_dir / "robot.toml"
    path.write_text(toml(data))
    with pytest.raises(RobotFileError, match=message) as caught:
        load_description(path)
    assert str(path.resolve()) in str(caught.value)
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('model = "humanoid.urdf"\nframes = {\n', r"not TOML.*line 2"),
        ("contact_radius = " + "9" * 5000, "not TOML, or not a value TOML reads: Exceeds the limit"),
        ("sole_size = " + "[" * 5000 + "]" * 5000, "values nested too deeply"),
        ("sole_size = [1, 2]\nsole_size = [1, 2]", "not TOML"),
        ('name = "caf\xe9"', "not UTF-8 text"),
    ],
    ids=["truncated", "5000 digits", "5000 deep", "twice", "latin-1"],
)
def test_a_file_that_is_not_toml_is_named_and_where(robot_dir, text, message):
    path = robot_dir / "robot.toml"
    path.write_bytes(text.encode("latin-1"))
    with pytest.raises(RobotDescriptionError, match=f"robot.toml: {message}") as caught:
        load_description(path)
    assert "\n" not in str(caught.value)


# --- fuzz: random values at random keys, random text: a description or a one-line error -------


def nested(inner: st.SearchStrategy) -> st.SearchStrategy:
    """Arrays and tables of ``inner`` values."""
    return st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=6), inner, max_size=3)


values = st.recursive(
    st.booleans()
    | st.integers(min_value=-(10**40), max_value=10**40)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=8),
    nested,
    max_leaves=8,
)
TABLES = ("frames", "force_sensors", "half_sitting", "drives", "step_timing", "step_limits")


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    where=st.sampled_from(sorted(shipped()) + [f"{t}.{k}" for t in TABLES for k in shipped().get(t, {})]),
    value=values | st.just(...),
)
def test_fuzzed_descriptions_load_or_raise_one_line_naming_the_file(robot_dir, where, value):
    data = shipped()
    table, _, key = where.rpartition(".")
    target = data[table] if table else data
    if value is ...:
        target.pop(key)
    else:
        target[key] = value
    path = robot_dir / "fuzzed.toml"
    path.write_text(toml(data))
    try:
        robot = load_description(path)
    except RobotFileError as exc:  # RobotDescriptionError and RobotFileMissing are ones
        assert str(path.parent.resolve()) in str(exc) and "\n" not in str(exc), str(exc)
    else:
        assert isinstance(robot, RobotDescription)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(text=st.text(max_size=200))
def test_fuzzed_text_loads_or_raises_one_line_naming_the_file(robot_dir, text):
    path = robot_dir / "text.toml"
    path.write_text(text, encoding="utf-8", errors="surrogatepass")
    with pytest.raises(RobotFileError) as caught:
        load_description(path)
    assert str(path.resolve()) in str(caught.value) and "\n" not in str(caught.value)


# --- the draft -------------------------------------------------------------------------------


def test_the_draft_of_the_shipped_urdf_finds_its_frames_sensors_and_sole(robot_dir):
    drafted = draft_description(robot_dir / "humanoid.urdf")
    (robot_dir / "humanoid.toml").write_text(drafted.text)
    robot = load_description(robot_dir / "humanoid.urdf")  # it loads as written
    frames = {key: spec.parent for key, spec in robot.frames.items()}
    assert set(frames) == set(LOGICAL_FRAMES)
    for side, s in (("left", "l"), ("right", "r")):
        assert frames[f"{side}_foot"] == f"{s}_foot"
        assert robot.frames[f"{side}_foot"].xyz == pytest.approx((0.0, 0.0, -SOLE_BELOW_FOOT_LINK))
        assert frames[f"{side}_ankle"] == f"{s}_ankle_roll_link"
        assert frames[f"{side}_wrist"] == f"{s}_wrist_pitch_link"
        assert frames[f"{side}_hand"] == f"{s}_hand"
        # the knees bent, the hip and ankle pitch turned back by half: the shank and thigh
        # lean by the same angle, the sole stays parallel to the pelvis
        knee = robot.half_sitting[f"{s}_knee"]
        assert knee > 0.3
        assert robot.half_sitting[f"{s}_hip_pitch"] + knee + robot.half_sitting[f"{s}_ankle_pitch"] == 0.0
    assert (frames["pelvis"], frames["torso"], frames["head"]) == ("pelvis", "torso", "head")
    assert robot.sole_size == pytest.approx(SOLE)
    assert dict(robot.force_sensors) == {
        f"{side}_{part}": f"{side[0]}_{part}_ft" for side in ("left", "right") for part in ("ankle", "wrist")
    }
    assert set(robot.force_sensors) == set(FORCE_SENSORS)
    # what it could not guess is said at the top: the tool points and the camera's place
    head = drafted.text.split("\n\n")[0]
    assert head.count("NOT GUESSED") == len(drafted.unguessed) == 3


def test_a_draft_without_sensor_welds_adds_sole_links(robot_dir):
    """A model whose feet hang on their ankle joints (no weld to read the ankle force through)
    gets a sole link welded under each foot."""
    text = (robot_dir / "humanoid.urdf").read_text()
    for side in ("l", "r"):  # the sensor weld becomes a (toe) joint: no weld between ankle and foot
        text = text.replace(
            f'<joint name="{side}_ankle_ft" type="fixed">',
            f'<joint name="{side}_ankle_ft" type="revolute"><limit lower="-0.1" upper="0.1" effort="10"/>',
        )
    (robot_dir / "nosensor.urdf").write_text(text)
    drafted = draft_description(robot_dir / "nosensor.urdf")
    data = tomllib.loads(drafted.text)
    assert [w["name"] for w in data["added_welds"]] == ["left_ankle_ft", "right_ankle_ft"]
    assert data["frames"]["left_foot"] == "left_sole_link"


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("<robot name='r'><link name='a'/><link name='b'/></robot>", "needs one root link"),
        ("<sdf version='1.7'/>", "not a URDF"),
        ("<robot name='r'><link name='base'/></robot>", "no left link"),
        ("<robot", "not well-formed XML"),
    ],
)
def test_a_model_the_draft_cannot_read_is_named(tmp_path, text, message):
    path = tmp_path / "bad.urdf"
    path.write_text(text)
    with pytest.raises(RobotFileError, match=message):
        draft_description(path)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    element=st.integers(0, 10_000),
    attribute=st.sampled_from(["name", "link", "xyz", "rpy", "lower", "upper", "effort", "size", "type"]),
    value=st.none()
    | st.sampled_from(["nan", "inf", "1e999", "", "pelvis", "l_foot", "0 0", "1 2 3 4", "fixed"])
    | st.text(max_size=6),
)
def test_a_fuzzed_urdf_is_drafted_or_refused_in_one_line_naming_it(robot_dir, element, attribute, value):
    """One attribute of one element of the shipped URDF deleted (None) or set to anything: the
    draft is a text or a RobotFileError naming the file, never an error from deep inside."""
    assert_mutated_model_is_drafted_or_refused(
        robot_dir / "humanoid.urdf", robot_dir / "fuzzed.urdf", element, attribute, value
    )


# --- the command line ------------------------------------------------------------------------


def test_robot_draft_prints_a_description_that_loads(robot_dir, capsys):
    assert cli.main(["robot", "draft", str(robot_dir / "humanoid.urdf")]) == 0
    captured = capsys.readouterr()
    (robot_dir / "humanoid.toml").write_text(captured.out)
    assert load_description(robot_dir / "humanoid.toml").base_body == "pelvis"
    assert "3 things not guessed" in captured.err


def test_robot_draft_of_a_missing_model_exits_2_naming_it(tmp_path, capsys):
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["robot", "draft", str(tmp_path / "absent.urdf")])
    assert exit_info.value.code == 2
    assert f"{tmp_path / 'absent.urdf'} does not exist" in capsys.readouterr().err


def test_run_with_a_broken_description_exits_2_naming_the_key(robot_dir, capsys):
    path = robot_dir / "humanoid.toml"
    path.write_text(path.read_text().replace("base_body =", "base_bodies ="))
    with pytest.raises(SystemExit) as exit_info:
        cli.main(["run", "walk", "--robot", str(path), "--out", str(robot_dir / "out")])
    assert exit_info.value.code == 2
    err = capsys.readouterr().err
    assert "unknown key 'base_bodies'" in err and str(path.resolve()) in err
    assert not (robot_dir / "out").exists()  # nothing simulated


def test_robot_option_help_says_a_path_is_taken(capsys):
    with pytest.raises(SystemExit):
        cli.main(["run", "--help"])
    assert "or a path ending with .toml, .urdf" in " ".join(capsys.readouterr().out.split())


def test_a_choice_parameter_with_paths_names_what_it_takes():
    robot = Parameter("robot", "choice", "a", "the robot", choices=("a", "b"), paths=(".toml",))
    assert robot.check("dir/x.TOML") == "dir/x.TOML"
    with pytest.raises(ValueError, match=r"robot = 'c': must be one of: a, b, or a path ending with \.toml"):
        robot.check("c")
    with pytest.raises(ValueError, match="paths are for a choice only"):
        Parameter("n", "float", 1.0, "a number", paths=(".toml",))
