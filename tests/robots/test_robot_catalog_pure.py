"""The robot catalog imports no pydrake: the peer benchmark reads TALOS from it in a virtual
environment without Drake (``make bench-peers``)."""

from __future__ import annotations

import subprocess
import sys


def test_the_catalog_the_draft_and_the_model_fixes_import_no_pydrake():
    code = (
        "import sys\n"
        "from drake_sot.robots.catalog import ROBOTS, get_robot\n"
        "from drake_sot.robots.urdf import prepare_urdf\n"
        "assert get_robot('embedded').name == 'embedded'  # built on first use\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'pydrake'))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    # The embedded description reads the embedded model's tables, which import pydrake: that
    # is the one description that may; TALOS and the G1 must not need it.
    code_talos = (
        "import sys\n"
        "from drake_sot.robots.catalog import ROBOTS, RobotDataMissing\n"
        "from drake_sot.robots.draft import draft_description\n"
        "from drake_sot.robots.mjcf import prepare_mjcf\n"
        "from drake_sot.robots.sdf import prepare_sdf\n"
        "from drake_sot.robots.urdf import prepare_urdf\n"
        "try:\n"
        "    ROBOTS['talos'](); ROBOTS['g1']()\n"
        "except RobotDataMissing:\n"
        "    pass\n"
        "print(sorted(m for m in sys.modules if m.split('.')[0] == 'pydrake'))\n"
    )
    out_talos = subprocess.run(
        [sys.executable, "-c", code_talos], capture_output=True, text=True, check=True
    ).stdout
    assert out_talos.strip() == "[]", out_talos
    assert out.strip() != "[]"  # the check sees pydrake when it is imported
