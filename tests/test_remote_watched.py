"""The signals a served run publishes after each tick for reads answered at once: a signal read
once is published until no client has read it for ``WATCH_EXPIRY`` s of wall time (a read the
socket thread answered from the published values counts), so that a signal read once does not
cost a port evaluation every tick for the rest of the run. Served in process, on a fake clock."""

import types

import pytest
from served import FakeNetwork, feet_and_posture, ticks

from drake_sot.app import serving as serving_module
from drake_sot.app.serving import WATCH_EXPIRY, Serving
from drake_sot.remote.protocol import Request

SIGNAL = "dyn.com"


@pytest.fixture(scope="module")
def built():
    return feet_and_posture()


class Clock:
    """A monotonic clock [s] that moves only when told."""

    def __init__(self):
        self.now = 1000.0

    def monotonic(self):
        return self.now


@pytest.fixture
def served(built, monkeypatch):
    clock = Clock()
    monkeypatch.setattr(
        serving_module,
        "wallclock",
        types.SimpleNamespace(monotonic=clock.monotonic, sleep=lambda seconds: None),
    )
    simulator = built.create_simulator()
    network = FakeNetwork()
    serving = Serving(simulator, built.remote, network, realtime=1e9)  # no pacing
    return simulator, serving, network, clock


def _read_once(simulator, serving, network):
    network.put(Request("read", 1, signal=SIGNAL))
    ticks(simulator, serving, 1)
    assert network.reply(1)["ok"], network.sent


def test_a_signal_read_once_is_published_until_no_client_read_it_for_the_expiry(served):
    simulator, serving, network, clock = served
    ticks(simulator, serving, 1)
    assert network.published == {}  # nothing read: nothing evaluated for the socket thread
    _read_once(simulator, serving, network)
    ticks(simulator, serving, 1)
    assert SIGNAL in network.published
    clock.now += WATCH_EXPIRY - 0.5
    ticks(simulator, serving, 1)
    assert SIGNAL in network.published  # within the expiry
    clock.now += 1.0
    ticks(simulator, serving, 1)
    assert SIGNAL not in network.published  # no read for WATCH_EXPIRY + 0.5 s
    network.put(Request("read", 2, signal=SIGNAL))  # read again: published again
    ticks(simulator, serving, 2)
    assert network.reply(2)["ok"] and SIGNAL in network.published


def test_reads_answered_from_the_published_values_keep_a_signal_published(served):
    simulator, serving, network, clock = served
    _read_once(simulator, serving, network)
    for _ in range(4):  # 4 expiries of wall time, the socket thread answering a read each second
        for _ in range(int(WATCH_EXPIRY)):
            clock.now += 1.0
            network.hits = {SIGNAL, "never.watched"}  # a hit of a signal not watched watches nothing
            ticks(simulator, serving, 1)
            assert SIGNAL in network.published and "never.watched" not in network.published
    clock.now += WATCH_EXPIRY + 0.5  # then no read at all
    ticks(simulator, serving, 1)
    assert SIGNAL not in network.published
