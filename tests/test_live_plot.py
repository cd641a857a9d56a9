"""The live plot's HTTP server: what it serves, what it refuses, and that no request line, however
malformed, stops it."""

from __future__ import annotations

import json
import math
import socket
import urllib.error
import urllib.request

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from drake_sot.app.live_plot import WINDOW, LivePlot
from drake_sot.app.status import ErrorSample


@pytest.fixture(scope="module")
def plot():
    plot = LivePlot(period=1.0)
    yield plot
    plot.close()


def _get(url: str) -> bytes:
    return urllib.request.urlopen(url, timeout=10).read()


def test_the_page_and_the_data_of_the_samples_shown(plot):
    assert b"<canvas" in _get(plot.url)
    for k in range(int(WINDOW) + 5):  # past the window: the oldest are dropped
        norms = {"log10 |e| taskA [m]": -float(k % 6), "log10 |e| taskA [rad]": math.nan}
        plot.show(ErrorSample(float(k), norms, ("taskA", "taskB")))
    data = json.loads(_get(plot.url + "data"))
    assert data["names"] == ["log10 |e| taskA [m]", "log10 |e| taskA [rad]"]
    kept = range(4, int(WINDOW) + 5)  # the samples of the last WINDOW s: t >= 34 - 30
    assert data["t"] == [float(k) for k in kept]
    assert data["series"]["log10 |e| taskA [m]"] == [-float(k % 6) for k in kept]
    assert set(data["series"]["log10 |e| taskA [rad]"]) == {None}  # NaN travels as null
    assert data["stack"] == ["taskA", "taskB"] and data["log_min"] < data["log_max"]


@pytest.mark.parametrize("path", ["/nothing", "/data/x", "/../etc/passwd", "/index.html", "/%00"])
def test_another_path_is_not_found(plot, path):
    with pytest.raises(urllib.error.HTTPError, match="404"):
        _get(plot.url.rstrip("/") + path)


def test_only_get_and_head_are_served(plot):
    request = urllib.request.Request(plot.url + "data", data=b"x", method="POST")
    with pytest.raises(urllib.error.HTTPError, match="501"):
        urllib.request.urlopen(request, timeout=10)


def test_it_listens_on_the_loopback_interface_only():
    with pytest.raises(ValueError, match="loopback"):
        LivePlot(host="0.0.0.0")
    with pytest.raises(ValueError, match="period"):
        LivePlot(period=math.nan)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=300) | st.text(max_size=200).map(lambda t: t.encode("utf-8", "surrogatepass")))
def test_no_request_line_stops_the_server(plot, raw):
    with socket.create_connection(("127.0.0.1", int(plot.url.rsplit(":", 1)[1].strip("/"))), timeout=10) as s:
        s.sendall(raw + b"\r\n\r\n")
        s.shutdown(socket.SHUT_WR)
        while s.recv(4096):  # whatever it answers, it answers and closes
            pass
    assert b"<canvas" in _get(plot.url)  # still serving
