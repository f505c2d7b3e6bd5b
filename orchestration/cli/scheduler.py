"""``batch --scheduler ADDRESS``: find out within seconds whether a Dask scheduler is there.

Dask's client retries a refused connection until its connect timeout (30 s by default) before it
gives up.  :func:`connect` first opens a plain TCP connection to the address (``tcp://`` and
``tls://``; port 8786 when none is given): nothing listening is said at once (connection refused),
a host that does not answer after :data:`PROBE_TIMEOUT`; then the client itself gets
:data:`CLIENT_TIMEOUT` (something listens there, but it may not be a scheduler).
"""

from __future__ import annotations

import socket
from urllib.parse import urlsplit

PROBE_TIMEOUT = 3.0  # [s] for the TCP connection
CLIENT_TIMEOUT = 10.0  # [s] for Dask's handshake once something listens
DEFAULT_PORT = 8786  # Dask's scheduler port


class SchedulerUnreachable(RuntimeError):
    """No Dask scheduler answers at the address; the message says what was tried."""


def host_port(address):
    """``(host, port)`` of a ``tcp://`` or ``tls://`` address (``host:port`` alone means tcp), or None
    for the other schemes (``inproc://``, ``ucx://``...: left to Dask)."""
    text = address if "://" in address else f"tcp://{address}"
    parts = urlsplit(text)
    if parts.scheme not in ("tcp", "tls"):
        return None
    try:
        port = parts.port or DEFAULT_PORT
    except ValueError as exc:
        raise SchedulerUnreachable(f"--scheduler {address}: not an address ({exc})") from None
    if not parts.hostname:
        raise SchedulerUnreachable(f"--scheduler {address}: no host in the address")
    return parts.hostname, port


def probe(address, timeout=PROBE_TIMEOUT):
    """Raise :class:`SchedulerUnreachable` when nothing accepts a TCP connection at ``address``."""
    hp = host_port(address)
    if hp is None:
        return
    try:
        with socket.create_connection(hp, timeout=timeout):
            pass
    except ConnectionRefusedError:
        raise SchedulerUnreachable(f"--scheduler {address}: nothing listens there (connection refused); "
                                   "is the Dask scheduler started (dask scheduler)?") from None
    except TimeoutError:
        raise SchedulerUnreachable(f"--scheduler {address}: no answer within {timeout:g} s") from None
    except OSError as exc:  # an unknown host name, no route...
        raise SchedulerUnreachable(f"--scheduler {address}: cannot connect ({exc.strerror or exc})") from None


def connect(address, timeout=CLIENT_TIMEOUT):
    """A ``distributed.Client`` of the scheduler at ``address``, or :class:`SchedulerUnreachable`
    within seconds.  The client is made in a thread of its own and waited for at most ``timeout``:
    Dask's own timeout covers the connection, not a peer that accepts it and never answers."""
    import threading

    from distributed import Client

    probe(address)
    made = {}

    def make():
        try:
            made["client"] = Client(address, timeout=timeout)
        except Exception as exc:  # noqa: BLE001 - handed to the caller below
            made["error"] = exc

    worker = threading.Thread(target=make, name="satmotor-dask-connect", daemon=True)
    worker.start()
    worker.join(timeout + 1.0)
    if "client" in made:
        return made["client"]
    why = f" ({made['error']})" if "error" in made else ""
    raise SchedulerUnreachable(f"--scheduler {address}: something listens there but no Dask scheduler "
                               f"answered within {timeout:g} s{why}")
