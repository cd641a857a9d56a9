"""The start of a local cluster's worker process (a Dask preload, see
:func:`drake_sot.studies.runner.run_study`).

- It ignores SIGINT, which a terminal's Ctrl-C sends to the whole process group; the study's
  process decides, cancels the runs and closes the cluster (a worker interrupted by itself would
  print its traceback and be restarted).
- It drops Dask's "Failed to communicate with scheduler during heartbeat" error
  (:class:`ClosingSchedulerFilter`): a local cluster's scheduler lives in the study's process, so
  a worker's heartbeat fails only when the study closes the cluster (or its process died), and
  a worker busy with a run is slow to close: its heartbeat then met the scheduler's closed
  connection and printed a traceback on the study's terminal after the user's Ctrl-C.
"""

from __future__ import annotations

import logging
import signal
import threading
from typing import Any

#: The logger of Dask's worker, where the heartbeat's error is logged (``distributed.worker``).
WORKER_LOGGER = "distributed.worker"
#: How Dask (distributed 2026.8) begins the heartbeat's error of a lost scheduler connection.
HEARTBEAT_FAILED = "Failed to communicate with scheduler during heartbeat"


class ClosingSchedulerFilter(logging.Filter):
    """Drops the records of :data:`WORKER_LOGGER` that say a heartbeat could not reach the scheduler
    (:data:`HEARTBEAT_FAILED`); keeps every other record."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith(HEARTBEAT_FAILED)


def quiet_closing_scheduler() -> None:
    """Install :class:`ClosingSchedulerFilter` on :data:`WORKER_LOGGER` (once)."""
    logger = logging.getLogger(WORKER_LOGGER)
    if not any(isinstance(f, ClosingSchedulerFilter) for f in logger.filters):
        logger.addFilter(ClosingSchedulerFilter())


def dask_setup(worker: Any) -> None:
    """Dask's preload hook, called in the worker's process as it starts (``worker``: unused)."""
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    quiet_closing_scheduler()
