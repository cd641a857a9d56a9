"""``drake-sot shell``: the interactive coshell of a ``drake-sot serve`` server.

Each line is a script command sent with ``run`` (``sot.push taskLH``, ``get dyn.com``),
except the shell's own: ``read SIGNAL``, ``pairs TASK``, ``write SIGNAL V1 V2 ...``, ``list``,
``help``, ``quit``. History is kept with readline (in ``~/.drake_sot_history``) when available.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import TextIO

from drake_sot.remote.client import Client, RemoteError

#: The port ``serve`` and ``shell`` use by default.
DEFAULT_PORT = 7777
#: The environment variable holding the token when ``--token`` is not given.
TOKEN_ENV = "DRAKE_SOT_TOKEN"

HELP = """shell commands:
  read SIGNAL            the value of SYSTEM.PORT at the last tick (e.g. read sot.errors)
  pairs TASK             a self-collision task's rows by name: distance [m], shapes (bodies)
                         (e.g. pairs taskSelfCollision)
  write SIGNAL V1 V2 ... write an allowlisted signal (e.g. write taskRH.position_des 0.3 -0.2 1.0)
  list                   systems, readable and writable signals, commands
  help                   this text, then the server's commands
  quit                   leave (also Ctrl-D)
anything else is one script line run on the server (e.g. sot.push taskLH, get dyn.com)"""


def execute(client: Client, line: str) -> str:
    """What the shell prints for ``line``; a refused request gives ``error: ...``."""
    words = line.split()
    if not words:
        return ""
    try:
        if words[0] == "read" and len(words) == 2:
            return " ".join(f"{x:.6g}" for x in client.read(words[1]))
        if words[0] == "pairs" and len(words) == 2:
            rows = client.read_pairs(words[1])
            return (
                "\n".join(
                    f"{row.distance:.6g} m  {row.shape_a} ({row.body_a})  {row.shape_b} ({row.body_b})"
                    for row in rows
                )
                or f"{words[1]}: no pair within its activation distance at t = {client.t:.3f} s"
            )
        if words[0] == "write" and len(words) >= 2:
            client.write(words[1], [float(x) for x in words[2:]])
            return f"written at t = {client.t:.3f} s"
        if words == ["list"]:
            return json.dumps(client.list(), indent=1)
        if words == ["help"]:
            return f"{HELP}\nserver: {client.run('help')}"
        return client.run(line)
    except (RemoteError, ValueError) as exc:
        return f"error: {exc}"


def shell_main(host: str, port: int, token: str | None, *, stdin: TextIO = sys.stdin) -> int:
    """The read-eval-print loop; 0 at the end of input or ``quit``, 1 when the server is unreachable."""
    try:
        client = Client(host, port, token=token)
    except (OSError, RemoteError) as exc:
        print(f"drake-sot shell: cannot connect to {host}:{port}: {exc}", file=sys.stderr)
        return 1
    interactive = stdin.isatty()
    if interactive:
        _history()
    with client:
        while True:
            try:
                line = input("sot> ") if interactive else stdin.readline()
            except EOFError:
                return 0
            if not interactive and not line:
                return 0
            if line.strip() in ("quit", "exit"):
                return 0
            try:
                output = execute(client, line.strip())
            except ConnectionError as exc:
                print(f"drake-sot shell: {exc}", file=sys.stderr)
                return 1
            if output:
                print(output, flush=True)


def _history() -> None:
    try:
        import readline
    except ImportError:  # not on every platform: the shell works without history
        return
    path = Path.home() / ".drake_sot_history"
    try:
        readline.read_history_file(path)
    except OSError:
        pass
    import atexit

    atexit.register(lambda: _save(readline, path))


def _save(readline, path: Path) -> None:
    try:
        readline.write_history_file(path)
    except OSError:
        pass
