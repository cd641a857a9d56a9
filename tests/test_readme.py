"""The README's Python example runs and does what it says (the hand moves by the requested offset)."""

import re
from pathlib import Path

import numpy as np

README = Path(__file__).resolve().parents[1] / "README.md"


def test_readme_example_reaches(capsys):
    code = re.search(r"```python\n(.*?)```", README.read_text(), re.S).group(1)
    namespace: dict = {}
    exec(compile(code, str(README), "exec"), namespace)
    stack = namespace["sot"].sot.list(namespace["simulator"].get_context())
    assert stack.index("taskRH") < stack.index("taskPosture")
    moved = namespace["sot"].frame_pose(namespace["simulator"].get_context(), "right_hand").translation()
    np.testing.assert_allclose(moved - namespace["X"].translation(), [0.2, 0.0, 0.1], atol=0.005)


def test_the_tested_versions_table_names_this_run():
    """The README's table of tested versions has a row for the running Python, and its drake, numpy
    and scipy are the ones installed: the versions it claims are the ones tests ran on."""
    import sys
    from importlib.metadata import version

    python = f"{sys.version_info[0]}.{sys.version_info[1]}"
    row_pattern = r"^\| (3\.[0-9, .]+) \| ([0-9.]+)[^|]*\| ([0-9.]+) \| ([0-9.]+) \|"
    rows = re.findall(row_pattern, README.read_text(), re.M)
    row = [r for r in rows if python in [p.strip() for p in r[0].split(",")]]
    assert len(row) == 1, f"no row (or several) for Python {python} in the README's tested versions: {rows}"
    _, drake, numpy, scipy = row[0]
    for name, claimed in (("drake", drake), ("numpy", numpy), ("scipy", scipy)):
        installed = version(name)
        assert installed == claimed or installed.startswith(claimed + "."), (name, installed, claimed)
