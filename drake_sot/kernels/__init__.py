"""The compiled core: the hot numerics of the pure modules in C++ (``drake_sot.kernels._compiled``,
built at install by ``setup.py``), and the choice between them and their numpy versions.

Each kernel's numpy version stays in its pure module, beside the call of the compiled one: it is the
oracle (the tests check that both agree on random inputs) and the fallback. :data:`compiled` is the
compiled module, or None when the package runs on the numpy kernels:

- ``DRAKE_SOT_KERNELS=numpy`` in the environment asks for the numpy kernels (nothing is printed);
  ``DRAKE_SOT_KERNELS=compiled`` or unset asks for the compiled ones;
- when the compiled module cannot be imported (not built: a failed optional build, a source checkout
  on ``PYTHONPATH``), or was built from other sources than those beside it (an editable install whose
  C++ changed since: ``make`` rebuilds it), the numpy kernels run and one line on stderr says why.

:data:`BACKEND` names the path taken (``"compiled"`` or ``"numpy"``) and :data:`REASON` why.
"""

from __future__ import annotations

import os
import pathlib
import sys
from types import ModuleType

from drake_sot.kernels.source_hash import source_hash

__all__ = ["BACKEND", "ENVIRONMENT", "REASON", "compiled"]

#: The environment variable that chooses the kernels: ``numpy`` or ``compiled`` (the default).
ENVIRONMENT = "DRAKE_SOT_KERNELS"
_CHOICES = ("compiled", "numpy")


def _load() -> tuple[ModuleType | None, str]:
    """The compiled module (or None) and why that path."""
    choice = os.environ.get(ENVIRONMENT, "") or "compiled"
    if choice not in _CHOICES:
        print(
            f"drake_sot: {ENVIRONMENT}={choice[:40]!r} is none of {', '.join(_CHOICES)}; "
            "using the compiled kernels",
            file=sys.stderr,
        )
    if choice == "numpy":
        return None, f"{ENVIRONMENT}=numpy"
    try:
        from drake_sot.kernels import _compiled
    except ImportError as error:
        reason = f"the compiled kernels could not be imported ({error})"
    else:
        built, here = _compiled.SOURCE_HASH, source_hash(pathlib.Path(__file__).parent)
        if here is None or built == here:
            return _compiled, "built from these sources"
        reason = f"the compiled kernels were built from other sources ({built}, these are {here}): rebuild"
    print(f"drake_sot: {reason}; running on the numpy kernels", file=sys.stderr)
    return None, reason


compiled, REASON = _load()
#: ``"compiled"`` or ``"numpy"``: the kernels this process runs.
BACKEND = "numpy" if compiled is None else "compiled"
