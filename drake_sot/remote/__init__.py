"""The remote command server (the coshell of Mansard et al. 2009, III-C) and its client.

:mod:`~drake_sot.remote.protocol` the JSON-lines protocol, :mod:`~drake_sot.remote.network`
the socket thread, :mod:`~drake_sot.remote.server` the ``RemoteCommandServer`` system of the
diagram, :mod:`~drake_sot.remote.serving` the loop that owns the simulator,
:mod:`~drake_sot.remote.client` the Python client, :mod:`~drake_sot.remote.shell` the shell.
"""

from drake_sot.remote.client import Client, RemoteError

__all__ = ["Client", "RemoteError"]
