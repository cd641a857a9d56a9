"""The robot tests use ``tests/headless.py``: make ``tests/`` importable when they run alone."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
