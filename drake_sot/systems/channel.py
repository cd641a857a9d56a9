"""``Channel``: the tele-cooperation link in one diagram, delay, jitter and loss both ways.

A thin Drake adapter over :class:`drake_sot.channel.Link` (one per direction): at every
period the system samples its two inputs, sends each as one packet, and delivers the
packets due by then. Its outputs depend on its state only, so it also breaks the
algebraic loop of a bilateral coupling (master → slave → master).
"""

from __future__ import annotations

import numpy as np
from pydrake.common.value import Value
from pydrake.systems.framework import Context, State

from drake_sot import validation
from drake_sot.channel import Link, LinkConfig
from drake_sot.systems.leaf import SotLeafSystem

#: The default configurations: 140 ms one way, no jitter, no loss, independent seeds.
FORWARD_DEFAULT = LinkConfig(seed=0)
BACKWARD_DEFAULT = LinkConfig(seed=1)

#: The two directions of the link, in the order of the state tuple.
DIRECTIONS = ("forward", "backward")


class Channel(SotLeafSystem):
    """Two emulated network directions between a master site and a slave site.

    ``forward`` runs master → slave (the operator's wrenches, head and gripper references in
    Evrard et al. 2009), ``backward`` slave → master (the robot's hand positions).

    Input ports:
        forward_in: (n_forward,) the vector the master sends, sampled each period.
        backward_in: (n_backward,) the vector the slave sends, sampled each period.

    Output ports (held between periods; they depend on the state only):
        forward_out: (n_forward,) what the slave receives: the newest packet arrived.
        backward_out: (n_backward,) what the master receives.
        forward_age, backward_age: (1,) [s] how old the held value is (time since it was
            sent; a large number, 1e9, before the first packet arrives).

    Args:
        forward_size, backward_size: lengths of the two vectors (>= 1).
        forward, backward: the :class:`~drake_sot.channel.LinkConfig` of each direction
            (delay, jitter, loss, seed); give the two different seeds for independent draws.
        period: [s] the sampling period (the control period).
        forward_initial, backward_initial: what each receiver holds before the first packet
            arrives (default zeros).
        name: the system's name.
    """

    def __init__(
        self,
        forward_size: int,
        backward_size: int,
        *,
        forward: LinkConfig = FORWARD_DEFAULT,
        backward: LinkConfig = BACKWARD_DEFAULT,
        period: float = 0.005,
        forward_initial: np.ndarray | None = None,
        backward_initial: np.ndarray | None = None,
        name: str = "channel",
    ) -> None:
        super().__init__()
        self.set_name(name)
        sizes = {
            "forward": validation.positive_int("forward_size", forward_size),
            "backward": validation.positive_int("backward_size", backward_size),
        }
        self._period = validation.positive("period", period, unit="s")
        initials = {"forward": forward_initial, "backward": backward_initial}
        configs = {"forward": forward, "backward": backward}
        #: The :class:`~drake_sot.channel.LinkConfig` of each direction, by name.
        self.configs = configs
        links = tuple(
            Link.start(
                configs[d],
                np.zeros(sizes[d])
                if initials[d] is None
                else validation.vector(f"{d}_initial", initials[d], sizes[d]),
            )
            for d in DIRECTIONS
        )
        self._links = self.DeclareAbstractState(Value[object](links))
        self._inputs = {d: self.DeclareVectorInputPort(f"{d}_in", sizes[d]) for d in DIRECTIONS}
        ticket = {self.abstract_state_ticket(self._links)}
        for i, d in enumerate(DIRECTIONS):
            self.DeclareVectorOutputPort(
                f"{d}_out",
                sizes[d],
                lambda c, out, i=i: out.SetFromVector(self._state(c)[i].value),
                prerequisites_of_calc=ticket,
            )
            self.DeclareVectorOutputPort(
                f"{d}_age",
                1,
                lambda c, out, i=i: out.SetFromVector([min(self._state(c)[i].age(c.get_time()), 1e9)]),
                prerequisites_of_calc={self.time_ticket(), *ticket},
            )
        self.DeclarePeriodicUnrestrictedUpdateEvent(self._period, 0.0, self._tick)

    def _state(self, context: Context) -> tuple[Link, Link]:
        return context.get_abstract_state(self._links).get_value()

    def links(self, context: Context) -> dict[str, Link]:
        """The two :class:`~drake_sot.channel.Link` values by direction (the system's own context)."""
        return dict(zip(DIRECTIONS, self._state(context), strict=True))

    def _tick(self, context: Context, state: State) -> None:
        now = context.get_time()
        links = tuple(
            link.step(now, self._inputs[d].Eval(context))
            for d, link in zip(DIRECTIONS, self._state(context), strict=True)
        )
        state.get_mutable_abstract_state(self._links).set_value(links)
