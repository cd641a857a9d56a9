"""The start of a local cluster's worker process (a Dask preload, see
:func:`drake_sot.studies.runner.run_study`): it ignores SIGINT, which a terminal's Ctrl-C sends
to the whole process group; the study's process decides, cancels the runs and closes the
cluster (a worker interrupted by itself would print its traceback and be restarted)."""

from __future__ import annotations

import signal
import threading
from typing import Any


def dask_setup(worker: Any) -> None:
    """Dask's preload hook, called in the worker's process as it starts (``worker``: unused)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
