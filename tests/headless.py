"""Headless Chromium screenshots of pages the project writes (replays)."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--disable-breakpad",
    "--disable-crash-reporter",
)


def chromium() -> str | None:
    """Path of Debian's chromium, or None."""
    return shutil.which("chromium") or shutil.which("chromium-browser")


def screenshot(
    page: Path, out: Path, *, size: str = "800,600", attempts: int = 3, timeout: float = 45.0
) -> np.ndarray:
    """Render ``page`` headless and return the screenshot's RGB pixels (h, w, 3) in [0, 1].

    Headless Chromium occasionally hangs at start-up on these machines (seen once in
    ~20 runs); a hung attempt is killed after ``timeout`` seconds, reported on stderr,
    and retried with a fresh profile, up to ``attempts`` times.
    """
    import matplotlib.image

    browser = chromium()
    if browser is None:
        raise FileNotFoundError("chromium is not installed")
    for attempt in range(1, attempts + 1):
        profile = out.parent / f"chromium-profile-{attempt}"
        command = [
            browser,
            *FLAGS,
            f"--user-data-dir={profile}",
            f"--screenshot={out}",
            f"--window-size={size}",
            # No --virtual-time-budget: with it, Chromium 150 hangs on the larger replays (TALOS,
            # the G1: ~10 MB of meshes) in every attempt, alone or under load; without it the
            # screenshot comes after the page's load, when the recorded scene is drawn (seen:
            # the TALOS replay in 3.8 s).
            "--timeout=20000",
            page.resolve().as_uri(),
        ]
        try:
            subprocess.run(command, capture_output=True, timeout=timeout, check=True)
            return matplotlib.image.imread(out)[..., :3]
        except subprocess.TimeoutExpired:
            print(f"chromium hung (attempt {attempt}/{attempts}), retrying", file=sys.stderr)
    raise TimeoutError(f"chromium did not render {page} in {attempts} attempts of {timeout} s")
