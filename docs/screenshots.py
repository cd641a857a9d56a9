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
import subprocess
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "tests"))
from headless import screenshot  # noqa: E402 - the tests' Chromium helper, one home

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
            screenshot(_page(view, tmp, "view"), IMAGES / "live_view.png", size="900,600")
            screenshot(_page(plot, tmp, "plot"), IMAGES / "live_plot.png", size="1200,480")
    finally:
        proc.terminate()
        proc.wait(timeout=30)


def _page(url: str, tmp: Path, name: str) -> Path:
    """A local page that shows ``url`` full-window (``screenshot`` takes files)."""
    page = tmp / f"{name}.html"
    page.write_text(
        f'<html><body style="margin:0"><iframe src="{url}" style="border:0;width:100vw;height:100vh">'
        "</iframe></body></html>"
    )
    return page


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
        screenshot(svg, IMAGES / "signal_graph.png", size=_svg_size(svg))
        screenshot(tmp / f"{args.scenario}.html", IMAGES / "replay.png", size="900,600")
        _served(args.scenario, args.at, tmp)
    for path in sorted(IMAGES.glob("*.png")):
        print(f"wrote {path.relative_to(REPO)}")


if __name__ == "__main__":
    main()
