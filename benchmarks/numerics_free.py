"""The "numerics free" variant of a closed loop (``bench_loop.py``): the same systems, ports and
plant, with the package's pure numerics replaced by the results of a recorded run.

A :class:`Recording` wraps every function and method of the pure modules (``drake_sot/*.py``: the
features, the tasks' arithmetic, the strict hierarchy and its inequalities, the pattern generator's
preview, the stabilizer, the torque law...) where the systems call them: the module attributes of
the pure modules and the names the systems' modules imported from them. While :meth:`recording`,
each outermost call (one made by a system, not by another pure function) stores its result in
order, per function; while :meth:`replaying`, each outermost call returns the next stored result of
its function without computing it. The simulation is deterministic, so the replayed run makes the
same calls in the same order and stays on the recorded trajectory (``bench_loop.py`` prints the
largest difference of the final positions, its "drift"): its cost is the shape's own (ports, cache,
pybind11, the plant, the Python of the systems) with the kernels free, the ceiling of what
compiling them can give. A call that raised while recording raises the same exception again.

Not replayed: constructors and dunder methods (an object's state is built as in the recorded
run), the plant queries (Drake's), and the systems' own Python around the calls.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import inspect
import pkgutil
from collections import deque
from collections.abc import Callable, Iterator
from types import FunctionType, ModuleType

import drake_sot
import drake_sot.systems

__all__ = ["Recording"]


def _pure_modules() -> list[ModuleType]:
    """The package's pure modules (top level, no Drake), imported."""
    return [
        importlib.import_module(f"drake_sot.{info.name}")
        for info in pkgutil.iter_modules(drake_sot.__path__)
        if not info.ispkg
    ]


def _system_modules() -> list[ModuleType]:
    return [
        importlib.import_module(f"drake_sot.systems.{info.name}")
        for info in pkgutil.iter_modules(drake_sot.systems.__path__)
    ]


class Recording:
    """The results of the pure functions' outermost calls in one run, to replay in another."""

    def __init__(self) -> None:
        self._results: dict[str, deque] = {}
        self._depth = 0
        self._mode = "off"
        self.replayed = 0

    def _wrap(self, key: str, function: Callable) -> Callable:
        @functools.wraps(function)
        def wrapper(*args, **kwargs):
            if self._depth or self._mode == "off":
                return function(*args, **kwargs)
            if self._mode == "replay":
                queue = self._results.get(key)
                if queue:
                    self.replayed += 1
                    raised, value = queue.popleft()
                    if raised:
                        raise value
                    return value
                return function(*args, **kwargs)  # past the recording: computed
            self._depth += 1
            try:
                value = function(*args, **kwargs)
            except Exception as error:  # replayed as it was raised, and re-raised here
                self._results.setdefault(key, deque()).append((True, error))
                raise
            finally:
                self._depth -= 1
            self._results.setdefault(key, deque()).append((False, value))
            return value

        return wrapper

    @contextlib.contextmanager
    def _patched(self) -> Iterator[None]:
        undo: list[tuple[object, str, object]] = []
        wrapped: dict[int, Callable] = {}

        def patch(owner: object, name: str, value: object, key: str) -> None:
            raw = inspect.getattr_static(owner, name)
            if isinstance(raw, staticmethod | classmethod):
                replacement = type(raw)(wrapped.setdefault(id(raw), self._wrap(key, raw.__func__)))
            else:
                replacement = wrapped.setdefault(id(value), self._wrap(key, value))
            undo.append((owner, name, raw))
            setattr(owner, name, replacement)

        pure = _pure_modules()
        pure_names = {module.__name__ for module in pure}
        for module in pure:
            for name, value in list(vars(module).items()):
                if isinstance(value, FunctionType) and value.__module__ == module.__name__:
                    patch(module, name, value, f"{module.__name__}.{name}")
                elif inspect.isclass(value) and value.__module__ == module.__name__:
                    for attribute, member in list(vars(value).items()):
                        if attribute.startswith("__"):
                            continue
                        function = getattr(member, "__func__", member)
                        if isinstance(function, FunctionType):
                            patch(value, attribute, member, f"{module.__name__}.{name}.{attribute}")
        for module in _system_modules():
            for name, value in list(vars(module).items()):
                if isinstance(value, FunctionType) and value.__module__ in pure_names:
                    patch(module, name, value, f"{value.__module__}.{value.__name__}")
        try:
            yield
        finally:
            for owner, name, raw in reversed(undo):
                setattr(owner, name, raw)

    @contextlib.contextmanager
    def recording(self) -> Iterator[None]:
        """Within: the outermost calls' results are stored."""
        with self._patched():
            self._mode = "record"
            try:
                yield
            finally:
                self._mode = "off"

    @contextlib.contextmanager
    def replaying(self) -> Iterator[None]:
        """Within: the outermost calls return the stored results, in order."""
        with self._patched():
            self._mode = "replay"
            try:
                yield
            finally:
                self._mode = "off"
