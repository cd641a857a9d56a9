"""The hash of the compiled core's C++ sources: ``setup.py`` builds it into the module, and
:mod:`drake_sot.kernels` compares it with the sources beside the module (an editable install whose
sources changed since its build runs on the numpy kernels and says so, instead of stale code).
Standard library only: ``setup.py`` imports this file by path, before the package exists."""

from __future__ import annotations

import hashlib
import pathlib

__all__ = ["source_hash"]


def source_hash(folder: pathlib.Path) -> str | None:
    """SHA-256 (hex, first 16 characters) of the ``*.cpp`` and ``*.h`` files of ``folder``, names and
    contents in name order; None when there are none (an installed wheel ships no sources)."""
    files = sorted([*folder.glob("*.cpp"), *folder.glob("*.h")])
    if not files:
        return None
    digest = hashlib.sha256()
    for path in files:
        digest.update(path.name.encode())
        digest.update(b"\0")
        digest.update(path.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:16]
