"""Context helpers shared by the systems: accept a system's own context or the root one,
and refuse to set in a context a value that an input port drives."""

from __future__ import annotations

from pydrake.systems.framework import Context, InputPort, LeafContext, System


def own_context(system: System, context: Context) -> Context:
    """``system``'s (mutable) context, given its own context or the root diagram's.

    Raises:
        RuntimeError: ``context`` is neither (Drake's message)."""
    if isinstance(context, LeafContext):  # its own, or another system's: Drake says which
        system.ValidateContext(context)
        return context
    # a diagram's: the root's. Tested by type, not by ValidateContext's exception (translated to
    # Python, it cost ~150 µs at each call: a served run's host asks at every tick)
    return system.GetMyMutableContextFromRoot(context)


def settable_context(
    system: System, context: Context, port: InputPort, *, command: str, what: str
) -> Context:
    """``system``'s own context (given it or the root's), to set ``what`` in it.

    When ``port`` has a value (it is connected, or fixed), ``what`` comes from that port
    and a value set in the context would be silently ignored: the command is refused.

    Raises:
        ValueError: ``"'<system>': cannot <command>: <what> comes from input port
            '<port>'; change its source instead"``.
    """
    context = own_context(system, context)
    if port.HasValue(context):
        raise ValueError(
            f"{system.get_name()!r}: cannot {command}: {what} comes from input port "
            f"{port.get_name()!r}; change its source instead"
        )
    return context
