"""The transport of the remote command server (the coshell of Mansard et al. 2009, III-C), with
no Drake: :mod:`~drake_sot.remote.protocol` the JSON-lines protocol,
:mod:`~drake_sot.remote.network` the socket thread, :mod:`~drake_sot.remote.client` the Python
client, :mod:`~drake_sot.remote.peer` a run's link to its peer, :mod:`~drake_sot.remote.shell`
the shell. The ``RemoteCommandServer`` system of the diagram is
:mod:`drake_sot.systems.command_server`; the loop that owns the simulator while serving is
:mod:`drake_sot.app.serving`.
"""

from drake_sot.remote.client import Client, RemoteError

__all__ = ["Client", "RemoteError"]
