"""The live plot of a served run: the task errors over time and the stack, in a browser page.

Meshcat's controls hold one value per slider; the plot shows how the errors went. A small HTTP
server on the loopback interface (its own thread) serves two paths:

- ``/``: a page that draws the last :data:`WINDOW` simulated seconds of each series of a
  :class:`~drake_sot.app.status.TaskErrorSampler` (``log10 |e| TASK [UNIT]``, on the same log
  scale as the sliders) and the stack, highest priority first, refreshed 4 times a second;
- ``/data``: the same as JSON, ``{"names": [...], "t": [...], "series": {name: [...]},
  "stack": [...], "log_min": ..., "log_max": ...}`` (null where a value is not finite).

Anything else is answered 404; only GET and HEAD are served. The serving loop calls
:meth:`LivePlot.show` with each sample; the server's thread only reads the last snapshot.
"""

from __future__ import annotations

import collections
import json
import math
import threading
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer

from drake_sot.app.status import LOG_MAX, LOG_MIN, SAMPLE_PERIOD, ErrorSample
from drake_sot.validation import positive

#: Simulated seconds of history the plot keeps.
WINDOW = 30.0

_PAGE = """<!doctype html>
<html><head><meta charset="utf-8"><title>drake_sot: task errors and stack</title>
<style>body{font:13px sans-serif;margin:8px}#wrap{display:flex;gap:16px}
#legend div{white-space:nowrap}#stack{min-width:12em}</style></head>
<body><h3>task errors, log10 |e| (m, rad, ...), and the stack</h3>
<div id="wrap"><canvas id="plot" width="900" height="420"></canvas>
<div><b>stack</b> (highest first)<ol id="stack"></ol><div id="legend"></div></div></div>
<script>
const colors = ["#1f77b4","#ff7f0e","#2ca02c","#d62728","#9467bd","#8c564b","#e377c2",
                "#7f7f7f","#bcbd22","#17becf","#393b79","#ad494a","#6b7a39","#7b4173"];
function draw(d) {
  const c = document.getElementById("plot"), g = c.getContext("2d");
  const W = c.width, H = c.height, L = 50, B = 25, T = 10;
  g.clearRect(0, 0, W, H); g.strokeStyle = "#ccc"; g.fillStyle = "black"; g.font = "11px sans-serif";
  const y = v => T + (H - B - T) * (1 - (v - d.log_min) / (d.log_max - d.log_min));
  for (let k = Math.ceil(d.log_min); k <= d.log_max; k++) {
    g.beginPath(); g.moveTo(L, y(k)); g.lineTo(W, y(k)); g.stroke(); g.fillText("1e" + k, 2, y(k) + 4);
  }
  if (!d.t.length) return;
  const t0 = d.t[0], t1 = Math.max(d.t[d.t.length - 1], t0 + 1e-6);
  const x = t => L + (W - L) * (t - t0) / (t1 - t0);
  g.fillText(t0.toFixed(1) + " s", L, H - 8); g.fillText(t1.toFixed(1) + " s", W - 50, H - 8);
  const legend = document.getElementById("legend"); legend.innerHTML = "";
  d.names.forEach((name, i) => {
    const color = colors[i % colors.length], v = d.series[name];
    g.strokeStyle = color; g.setLineDash(i < colors.length ? [] : [6, 3]); g.beginPath();
    let on = false;
    v.forEach((value, k) => {
      if (value === null) { on = false; return; }
      if (on) g.lineTo(x(d.t[k]), y(value)); else g.moveTo(x(d.t[k]), y(value));
      on = true;
    });
    g.stroke();
    const row = document.createElement("div"); row.style.color = color; row.textContent = name;
    legend.appendChild(row);
  });
  const stack = document.getElementById("stack"); stack.innerHTML = "";
  d.stack.forEach(name => {
    const li = document.createElement("li"); li.textContent = name; stack.appendChild(li);
  });
}
async function poll() {
  try { draw(await (await fetch("data")).json()); } catch (e) {}
  setTimeout(poll, 250);
}
poll();
</script></body></html>
"""


class LivePlot:
    """Serves the live plot on ``host`` (loopback) at a free ``port`` (0) or the one given; the
    series are those of the samples it is shown, in their order.

    Args:
        period: simulated seconds between two samples (to size the history of :data:`WINDOW`).
        host, port: where to listen; the loopback interface only.

    Raises:
        ValueError: ``host`` is not a loopback address, or ``period`` not finite and > 0.
        OSError: the port cannot be bound.
    """

    def __init__(self, period: float = SAMPLE_PERIOD, *, host: str = "127.0.0.1", port: int = 0) -> None:
        if host not in ("127.0.0.1", "localhost", "::1"):
            raise ValueError(f"host = {host!r}: the live plot listens on the loopback interface only")
        period = positive("period", period, unit="s")
        self._samples: collections.deque[ErrorSample] = collections.deque(maxlen=int(WINDOW / period) + 1)
        self._lock = threading.Lock()
        plot = self

        class Handler(BaseHTTPRequestHandler):
            timeout = 10

            def do_GET(self) -> None:
                self._answer(body=True)

            def do_HEAD(self) -> None:
                self._answer(body=False)

            def _answer(self, *, body: bool) -> None:
                path = self.path.split("?", 1)[0]
                if path == "/":
                    payload, kind = _PAGE.encode(), "text/html; charset=utf-8"
                elif path == "/data":
                    payload, kind = plot._encode(), "application/json"
                else:
                    self.send_error(404)
                    return
                self.send_response(200)
                self.send_header("Content-Type", kind)
                self.send_header("Content-Length", str(len(payload)))
                self.send_header("Cache-Control", "no-store")
                self.end_headers()
                if body:
                    self.wfile.write(payload)

            def log_message(self, format: str, *args: object) -> None:
                pass  # the served run's stdout is the client's: no access log there

        self._server = ThreadingHTTPServer((host, port), Handler)
        self._server.daemon_threads = True
        self._thread = threading.Thread(target=self._server.serve_forever, name="live-plot", daemon=True)
        self._thread.start()

    @property
    def url(self) -> str:
        """The page's address."""
        host, port = self._server.server_address[:2]
        return f"http://{host}:{port}/"

    def show(self, sample: ErrorSample) -> None:
        """Add ``sample`` to the plot (the oldest beyond :data:`WINDOW` is dropped)."""
        with self._lock:
            self._samples.append(sample)

    def _encode(self) -> bytes:
        """The ``/data`` answer (encoded in the server's thread, when a page asks)."""
        with self._lock:
            samples = list(self._samples)
        names = list(samples[-1].norms) if samples else []

        def finite(x: float) -> float | None:
            return x if math.isfinite(x) else None

        return json.dumps(
            {
                "names": names,
                "t": [s.t for s in samples],
                "series": {name: [finite(s.norms.get(name, math.nan)) for s in samples] for name in names},
                "stack": list(samples[-1].stack) if samples else [],
                "log_min": LOG_MIN,
                "log_max": LOG_MAX,
            },
            allow_nan=False,
        ).encode()

    def close(self) -> None:
        """Stop serving (idempotent)."""
        self._server.shutdown()
        self._server.server_close()
