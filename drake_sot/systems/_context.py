"""Accept either a system's own context or the root (diagram) context."""

from __future__ import annotations

from pydrake.systems.framework import Context, System


def own_context(system: System, context: Context) -> Context:
    """``system``'s (mutable) context, given its own context or the root diagram's."""
    try:
        system.ValidateContext(context)
        return context
    except RuntimeError:
        return system.GetMyMutableContextFromRoot(context)
