"""The emulated link: delay, jitter, loss, hold, reproducibility (drake_sot.channel)."""

import math

import numpy as np
import pytest

from drake_sot.channel import DEFAULT_DELAY, MAX_DELAY, Link, LinkConfig

DT = 0.005


def _run(config: LinkConfig, values, dt: float = DT):
    """Received value at each tick when ``values[k]`` is sent at ``k dt`` (send then receive)."""
    link = Link.start(config, np.zeros(1))
    received = []
    for k, v in enumerate(values):
        link = link.step(k * dt, [v])
        received.append(link.value[0])
    return np.array(received)


@pytest.mark.parametrize("delay", [0.0, 0.07, DEFAULT_DELAY, 0.1234, MAX_DELAY])
def test_a_step_arrives_delay_later_within_one_period(delay):
    n, t_step = 400, 0.5
    times = np.arange(n) * DT
    received = _run(LinkConfig(delay=delay), (times >= t_step - 1e-12).astype(float))
    arrival = times[np.argmax(received > 0.5)]
    # Sampled at DT, the step is seen at the first tick at or after t_step + delay.
    assert t_step + delay - 1e-9 <= arrival < t_step + delay + DT


def test_the_default_delay_is_half_the_munich_tsukuba_round_trip():
    assert DEFAULT_DELAY == pytest.approx(0.280 / 2)


def test_a_lost_packet_leaves_the_last_value_held():
    loss, delay_ticks, n = 0.3, 28, 4000
    received = _run(LinkConfig(delay=delay_ticks * DT, loss=loss, seed=7), np.arange(n, dtype=float))
    after = received[delay_ticks + 1 :]
    ticks = np.arange(delay_ticks + 1, n)
    fresh = after == ticks - delay_ticks
    held = after == received[delay_ticks:-1]
    assert np.all(fresh | held)  # each tick: the packet sent delay ago, or the previous value
    # Lost packets are Bernoulli(loss): the held fraction within 4 standard deviations.
    sigma = math.sqrt(loss * (1 - loss) / len(after))
    assert abs(np.mean(~fresh) - loss) < 4 * sigma


def test_jitter_keeps_each_delay_within_its_band_and_never_goes_back():
    delay, jitter, n = 0.1, 0.03, 4000
    link = Link.start(LinkConfig(delay=delay, jitter=jitter, seed=3), np.zeros(1))
    ages, values = [], []
    for k in range(n):
        link = link.step(k * DT, [float(k)])
        ages.append(link.age(k * DT))
        values.append(link.value[0])
    ages = np.array(ages[200:])
    # The age of the held value: at least delay - jitter (the freshest possible packet);
    # at most delay + jitter + one period (a packet is seen at the first tick after arrival).
    assert ages.min() >= delay - jitter - 1e-9
    assert ages.max() <= delay + jitter + DT + 1e-9
    assert np.all(np.diff(values) >= 0)  # a late packet never replaces a newer one
    assert ages.min() < delay - 0.8 * jitter  # and the jitter is really spread over its band


def test_the_same_seed_gives_the_same_packets_and_another_seed_others():
    values = np.arange(2000, dtype=float)
    a = _run(LinkConfig(delay=0.1, jitter=0.02, loss=0.2, seed=11), values)
    b = _run(LinkConfig(delay=0.1, jitter=0.02, loss=0.2, seed=11), values)
    c = _run(LinkConfig(delay=0.1, jitter=0.02, loss=0.2, seed=12), values)
    np.testing.assert_array_equal(a, b)
    assert np.any(a != c)


def test_before_the_first_arrival_the_receiver_holds_the_initial_value():
    link = Link.start(LinkConfig(delay=0.1), [4.0, 5.0])
    link = link.step(0.0, [1.0, 2.0]).receive(0.05)
    np.testing.assert_array_equal(link.value, [4.0, 5.0])
    assert link.age(0.05) == math.inf


@pytest.mark.parametrize(
    "kwargs, word",
    [
        ({"delay": 0.31}, "LinkConfig.delay"),
        ({"delay": -0.01}, "LinkConfig.delay"),
        ({"delay": float("nan")}, "LinkConfig.delay"),
        ({"delay": 0.2, "jitter": 0.2}, "LinkConfig.jitter"),
        ({"loss": 1.0}, "LinkConfig.loss"),
        ({"loss": float("nan")}, "LinkConfig.loss"),
        ({"seed": -1}, "LinkConfig.seed"),
    ],
)
def test_bad_parameters_are_refused_by_name(kwargs, word):
    with pytest.raises(ValueError, match=word):
        LinkConfig(**kwargs)


def test_a_bad_sample_is_refused_by_name():
    link = Link.start(LinkConfig(), np.zeros(2))
    with pytest.raises(ValueError, match="value"):
        link.send(0.0, [1.0, float("nan")])
    with pytest.raises(ValueError, match="value"):
        link.send(0.0, [1.0])


@pytest.mark.parametrize(
    "config", [LinkConfig(delay=0.14), LinkConfig(delay=0.05, jitter=0.03, loss=0.25, seed=5)]
)
def test_a_receiving_end_fed_the_senders_arrivals_delivers_at_the_ticks_of_one_link(config):
    # The two-process mode: the sender draws each packet's arrival (send), the receiver in the
    # other process carries the packets with it (carry) in batches of its own, each packet known
    # before the first tick it can be due at (sent at most delay - jitter before it). It must
    # hold, tick by tick, what one link (send then receive each tick, the Channel) holds.
    n = 600
    rng = np.random.default_rng(0)
    one = Link.start(config, np.zeros(1))
    sender = Link.start(config, np.zeros(1))
    receiver = Link.start(None, np.zeros(1))
    packets, carried = [], 0
    lost = 0
    for k in range(n):
        t = k * DT
        one = one.step(t, [float(k)])
        sender = sender.send(t, [float(k)])
        packets.append((t, sender.last_arrival, [float(k)]))
        lost += math.isinf(sender.last_arrival)
        # what the receiver has by its tick t: every packet sent by t - (delay - jitter), and a
        # random number of later ones (the network's batching)
        due = sum(1 for s, _, _ in packets if s <= t - config.min_delay + 1e-12)
        upto = min(len(packets), max(due, carried + int(rng.integers(0, 4))))
        for s, arrival, value in packets[carried:upto]:
            receiver = receiver.carry(s, arrival, value)
        carried = max(carried, upto)
        receiver = receiver.receive(t)
        assert receiver.value[0] == one.value[0], t
        assert receiver.sent_at == one.sent_at
    assert one.value[0] > n / 2  # the values flowed
    assert (lost > 0) == (config.loss > 0)


def test_a_receiving_end_cannot_draw_and_a_carried_packet_arrives_after_it_is_sent():
    with pytest.raises(ValueError, match="receiving end"):
        Link.start(None, [0.0]).send(0.0, [1.0])
    with pytest.raises(ValueError, match="arrival = 0.5"):
        Link.start(None, [0.0]).carry(1.0, 0.5, [1.0])
    assert Link.start(None, [0.0]).carry(1.0, math.inf, [1.0]).receive(1e9).value[0] == 0.0  # lost
