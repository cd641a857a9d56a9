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
