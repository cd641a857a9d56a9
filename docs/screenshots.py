"""The README's pictures, made from a run: the signal graph, the live view and the live plot of a
served run, and the recorded replay, each rendered by headless Chromium into ``docs/images/``.

    PYTHONPATH=. .venv/bin/python docs/screenshots.py [--scenario walk_then_interact] [--at 6]

Runs ``drake-sot run SCENARIO --duration AT --out TMP`` (the signal graph and the replay), then
``drake-sot serve SCENARIO`` until its simulated time passes ``AT`` s (the live view and plot).
Needs Debian's chromium (``make test`` installs it).
"""

from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from headless import FLAGS, chromium, screenshot  # noqa: E402 - the tests' Chromium helper, one home

from drake_sot.remote import Client  # noqa: E402

IMAGES = REPO / "docs" / "images"
DRAKE_SOT = [sys.executable, "-m", "drake_sot.app.cli"]


def _svg_size(svg: Path) -> str:
    """The window size (``W,H`` px) that shows the whole SVG, from its ``width``/``height`` in pt."""
    text = svg.read_text()[:2000]
    width, height = (float(re.search(rf'{key}="([\d.]+)pt"', text).group(1)) for key in ("width", "height"))
    return f"{int(width * 4 / 3) + 16},{int(height * 4 / 3) + 16}"


def _served(scenario: str, at: float, tmp: Path) -> None:
    """Serve ``scenario``; once past ``at`` s, shoot the live view and the live plot."""
    proc = subprocess.Popen(
        [*DRAKE_SOT, "serve", scenario, "--port", "0", "--duration", "600"],
        stdout=subprocess.PIPE,
        text=True,
        cwd=REPO,
    )
    try:
        host, port = re.fullmatch(r"serving on (\S+):(\d+)\n", proc.stdout.readline()).groups()
        view = proc.stdout.readline().rsplit(" ", 1)[1].strip()
        plot = proc.stdout.readline().rsplit(" ", 1)[1].strip()
        with Client(host, int(port), timeout=120.0) as client:
            client.read("dyn.com")
            while client.t < at:
                client.read("dyn.com")
            _shoot_url(view, IMAGES / "live_view.png", "900,600", tmp)
            _shoot_url(plot, IMAGES / "live_plot.png", "1200,480", tmp)
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def _shoot_url(url: str, out: Path, size: str, tmp: Path) -> None:
    """Headless Chromium's screenshot of a served page (the live ones; :func:`screenshot` takes files)."""
    profile = tmp / f"profile-{out.stem}"
    command = [chromium(), *FLAGS, f"--user-data-dir={profile}", f"--screenshot={out}"]
    command += [f"--window-size={size}", "--timeout=8000", url]
    subprocess.run(command, capture_output=True, timeout=60, check=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--scenario", default="walk_then_interact")
    parser.add_argument("--at", type=float, default=6.0, help="simulated seconds before the shots")
    args = parser.parse_args()
    IMAGES.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        subprocess.run(
            [*DRAKE_SOT, "run", args.scenario, "--duration", str(args.at), "--out", str(tmp)], check=True
        )
        svg = tmp / f"{args.scenario}.svg"
        for page, name, size in (
            (svg, "signal_graph", _svg_size(svg)),
            (tmp / f"{args.scenario}.html", "replay", "900,600"),
        ):
            screenshot(page, tmp / f"{name}.png", size=size)  # its Chromium profile beside it, in tmp
            shutil.copyfile(tmp / f"{name}.png", IMAGES / f"{name}.png")
        _served(args.scenario, args.at, tmp)
    for path in sorted(IMAGES.glob("*.png")):
        print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
