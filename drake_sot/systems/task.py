"""``Task``: features → ``(e, J, ė*)`` with ``ė* = -λ e + feedforward`` (Mansard, Stasse, Evrard,
Kheddar 2009, eq. 3 and 10)."""

from __future__ import annotations

import math

import numpy as np
from pydrake.common.value import AbstractValue, Value
from pydrake.systems.framework import AbstractParameterIndex, Context, InputPort, ValueProducer

from drake_sot import features as fmath
from drake_sot.features import SelectionLike
from drake_sot.gains import MAX_GAIN_PERIOD, AdaptiveGain, Gain, check_gain_period, validate_gain
from drake_sot.signals import FeatureSignal, TaskSignal
from drake_sot.stack import task_name
from drake_sot.systems._context import own_context, settable_context
from drake_sot.systems.features import Feature
from drake_sot.systems.leaf import SotLeafSystem
from drake_sot.validation import positive

#: Name of the optional input port that drives λ.
GAIN_PORT = "gain"


class Task(SotLeafSystem):
    """A task: the concatenation of one or more features and a gain.

    ``e = [e_1; e_2; ...]`` (Mansard et al. 2009, eq. 10), ``J = [J_1; J_2; ...]`` and the desired
    error rate ``ė* = -λ e + feedforward`` (eq. 3, plus the feed-forward of moving
    references). λ is a constant or an :class:`~drake_sot.gains.AdaptiveGain` of ‖e‖,
    held in a parameter that :meth:`set_gain` changes at run time, unless the ``gain``
    input port is connected: λ then comes from that port (e.g. a
    :class:`~drake_sot.systems.sequencer.TaskSequencer` output) and :meth:`set_gain` is
    refused, not ignored.

    The range of λ: finite and > 0 [1/s], and, once the task knows the control period ``dt``
    at which its law is integrated (``period``, or :meth:`use_period`, which the
    ``StackOfTasks`` it feeds calls with its own period), ``λ·dt <=``
    :data:`~drake_sot.gains.MAX_GAIN_PERIOD` (1: beyond it, explicit Euler's
    ``e_{k+1} = (1 - λ dt) e_k`` overshoots the goal at every tick; see :mod:`drake_sot.gains`).

    Input ports:
        gain: optional (1,), λ [1/s]; when connected it must be finite, > 0 and within the
            range above (else a RuntimeError naming the task when the task is evaluated).
            "gain" is therefore not a valid feature name.
        <feature name>: one per feature added with :meth:`add`, abstract
            :class:`~drake_sot.signals.FeatureSignal` (plug the feature's ``feature`` output).
    Output ports:
        task: abstract :class:`~drake_sot.signals.TaskSignal` for ``StackOfTasks``.

    Example (the paper's ``new Task taskCom; taskCom.add featureCom``)::

        task_com = builder.AddSystem(Task("taskCom", gain=2.0))
        builder.Connect(feature_com.GetOutputPort("feature"), task_com.add(feature_com))
    """

    def __init__(self, name: str, *, gain: Gain = 1.0, period: float | None = None) -> None:
        super().__init__()
        self.set_name(task_name(name))
        gain = validate_gain(gain, name=name, period=period)
        self._period: float | None = None if period is None else float(period)
        # (input port, dimension, rows of the feature's output the task keeps or None for all)
        self._features: list[tuple[InputPort, int, np.ndarray | slice | None]] = []
        self._units: list[str] = []
        # Value[object]: the parameter holds a float or an AdaptiveGain.
        self._gain = self.DeclareAbstractParameter(Value[object](gain))
        self._default_gain = gain
        self._gain_input = self.DeclareVectorInputPort(GAIN_PORT, 1)
        # λ now, recomputed (and checked) only when the gain input or parameter changes: one
        # evaluation a tick instead of asking whether the input is connected and reading the parameter.
        self._gain_now = self.DeclareCacheEntry(
            "gain now",
            ValueProducer(
                allocate=lambda: Value[object](gain),
                calc=lambda context, value: value.set_value(self._current_gain(context)),
            ),
            {
                self.input_port_ticket(self._gain_input.get_index()),
                self.abstract_parameter_ticket(AbstractParameterIndex(self._gain)),
            },
        )
        self.DeclareAbstractOutputPort(
            "task",
            lambda: AbstractValue.Make(TaskSignal(name, np.zeros(0), np.zeros((0, 0)), np.zeros(0))),
            self._calc_task,
            prerequisites_of_calc={self.all_input_ports_ticket(), self.all_parameters_ticket()},
        )

    @property
    def dimension(self) -> int:
        """Total dimension m of the task (sum of its features' selected components)."""
        return sum(m for _, m, _ in self._features)

    def add(self, feature: Feature, *, selection: SelectionLike = None) -> InputPort:
        """Add a feature (the paper's ``task.add feature``) and return the input port to plug it into.

        ``selection`` keeps some of the feature's (already selected) components in this
        task, as a feature's own selection does: several tasks can then share one feature
        (e.g. a hand's position and orientation tasks at different priorities read one
        6D hand feature, computed once per tick). Raises ValueError as the feature's
        selection does (wrong length, nothing selected).
        """
        name = feature.get_name()
        if name == GAIN_PORT:
            raise ValueError(
                f"task {self.get_name()!r}: a feature cannot be named {GAIN_PORT!r} "
                "(the name of the gain input port)"
            )
        if self.HasInputPort(name):
            raise ValueError(f"task {self.get_name()!r} already has a feature named {name!r}")
        rows = (  # checked before the port is declared: a refused call leaves the task as it was
            None
            if selection is None
            else fmath.selection_indices(
                selection, feature.dimension, name=f"selection of {name!r} in task {self.get_name()!r}"
            )
        )
        port = self.DeclareAbstractInputPort(
            name, AbstractValue.Make(FeatureSignal(np.zeros(0), np.zeros((0, 0)), np.zeros(0)))
        )
        if rows is not None and rows.size and (np.diff(rows) == 1).all():
            rows = slice(int(rows[0]), int(rows[-1]) + 1)  # consecutive components: views, not copies
        self._features.append((port, feature.dimension if rows is None else _count(rows), rows))
        units = np.array(feature.units, dtype=object)
        self._units.extend(units if rows is None else units[rows])
        return port

    @property
    def units(self) -> tuple[str, ...]:
        """The unit of each component of the task's error (its features' :attr:`Feature.units`,
        in the order they were added)."""
        return tuple(self._units)

    @property
    def period(self) -> float | None:
        """The control period [s] at which the task's law is integrated (None: not known yet)."""
        return self._period

    def use_period(self, period: float) -> None:
        """Declare the control period ``period`` [s] at which a solver integrates this task's law
        (``StackOfTasks`` calls it with its own): the constructor's gain is checked against it
        (``λ·period <= MAX_GAIN_PERIOD``) and so is every later one. Raises ValueError naming the
        task when the gain is out of that range, or when the task already has another period."""
        period = positive(f"task {self.get_name()!r}: control period", period, unit="s")
        if self._period is not None and self._period != period:
            raise ValueError(
                f"task {self.get_name()!r}: control period {float(period):g} s, but the task is "
                f"integrated at {self._period:g} s already (one solver, one period)"
            )
        check_gain_period(self._default_gain, period, name=self.get_name())
        self._period = period

    def set_gain(self, context: Context, gain: Gain) -> None:
        """Change λ at run time (own or root context); refused when the ``gain`` input is connected,
        and out of the range of the class docstring (ValueError naming the task, λ and the period)."""
        context = settable_context(self, context, self._gain_input, command="set_gain", what="the gain")
        context.get_mutable_abstract_parameter(self._gain).set_value(
            validate_gain(gain, name=self.get_name(), period=self._period)
        )

    def gain(self, context: Context) -> Gain:
        """λ now: the ``gain`` input's value when connected, else the parameter (own or root context)."""
        return self._current_gain(own_context(self, context))

    def _current_gain(self, context: Context) -> Gain:
        if self._gain_input.HasValue(context):
            value = float(self._gain_input.Eval(context)[0])
            if not (math.isfinite(value) and value > 0.0):
                raise RuntimeError(
                    f"task {self.get_name()!r}: gain {value} on input port {GAIN_PORT!r} "
                    "must be finite and > 0"
                )
            if self._period is not None and not (value * self._period <= MAX_GAIN_PERIOD):
                try:  # the check's message, built only when it fails
                    check_gain_period(value, self._period, name=self.get_name())
                except ValueError as error:
                    raise RuntimeError(f"{error} (on input port {GAIN_PORT!r})") from None
            return value
        return context.get_abstract_parameter(self._gain).get_value()

    def _calc_task(self, context: Context, value: AbstractValue) -> None:
        features = self._features
        if len(features) == 1:  # the common case: one feature, no concatenation
            port, _, rows = features[0]
            e, J, ff = _rows(port.Eval(context), rows)
        elif not features:
            raise RuntimeError(f"task {self.get_name()!r} has no feature: call add() before building")
        else:
            signals = [_rows(port.Eval(context), rows) for port, _, rows in features]
            e = np.concatenate([s[0] for s in signals])
            J = np.vstack([s[1] for s in signals])
            ff = np.concatenate([s[2] for s in signals])
        gain = self._gain_now.Eval(context)
        if isinstance(gain, AdaptiveGain):  # ‖e‖ only for a gain that depends on it
            gain = gain(math.sqrt(float(e @ e)))
        value.set_value(TaskSignal(self.get_name(), e, J, ff - gain * e))


def _count(rows: np.ndarray | slice) -> int:
    """How many components ``rows`` (indices, or a slice of consecutive ones) keeps."""
    return rows.stop - rows.start if isinstance(rows, slice) else int(rows.size)


def _rows(
    signal: FeatureSignal, rows: np.ndarray | slice | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(e, J, feedforward)`` of a feature signal, restricted to ``rows`` (None: all)."""
    if rows is None:
        return signal.error, signal.jacobian, signal.feedforward
    return signal.error[rows], signal.jacobian[rows], signal.feedforward[rows]
