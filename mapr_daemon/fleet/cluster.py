"""The Dask cluster a fleet run works on: a local one, or a client of an existing scheduler.

Light on purpose (``distributed`` is imported inside the functions): ``mapr fleet`` checks a
``--scheduler`` address before it reads any configuration. A scheduler that cannot be
reached, or that is lost mid-run, is a :class:`~mapr_daemon.errors.ClusterError` named in one
line within :data:`CONNECT_S` seconds (Dask's own connect timeout, 30 s, is set to it), with
Dask's loggers silenced (:func:`silence_dask_logs`): they would print tracebacks.
"""

from __future__ import annotations

import contextlib
import logging
from typing import TYPE_CHECKING

from mapr_daemon.errors import ClusterError

if TYPE_CHECKING:
    from distributed import Client

CONNECT_S = 5.0
"""Default time to reach a scheduler (``mapr fleet --connect-timeout``, whose default is
this); Dask's own default, 30 s, would leave a mistyped address silent for half a minute."""
NETWORK_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")
"""Address schemes of a scheduler another process can reach (Dask's ``inproc://`` is a
cluster inside one process)."""


def dashboard_available() -> bool:
    """Whether Dask can serve its dashboard here: it needs bokeh (``pip install
    'mapr[dashboard]'``); without it the dashboard's page only says so."""
    import importlib.util

    return importlib.util.find_spec("bokeh") is not None


def local_client(workers: int | None, *, dashboard: bool = True) -> Client:
    """A local Dask cluster of ``workers`` single-threaded processes (None: one per core),
    with its dashboard when ``dashboard`` and bokeh is installed."""
    from distributed import Client, LocalCluster

    served = dashboard and dashboard_available()
    # the scheduler's HTTP server (health, metrics) always runs: on a free port, not 8787
    cluster = LocalCluster(  # type: ignore[no-untyped-call]
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=":0",
        scheduler_kwargs={"dashboard": served}, silence_logs=logging.ERROR)
    return Client(cluster)  # type: ignore[no-untyped-call]


def scheduler_problem(address: str) -> str | None:
    """What is wrong with ``address`` as a scheduler address (``tcp://host:port``, Dask's
    own parsing and schemes), or None when it is well formed. Nothing is contacted."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address, strict=False)
    except ValueError as error:
        return f"--scheduler {address!r}: {error}"
    if scheme not in NETWORK_SCHEMES:
        return (f"--scheduler {address!r}: the scheme must be one of "
                f"{', '.join(NETWORK_SCHEMES)} (as in tcp://HOST:8786), not {scheme!r}")
    try:
        host, port = parse_host_port(location)
    except ValueError as error:
        return f"--scheduler {address!r}: {error} (as in tcp://HOST:8786)"
    if not host or any(c.isspace() for c in host) or not 0 < int(port) < 65536:
        return f"--scheduler {address!r}: expected {scheme}://HOST:PORT, PORT 1-65535"
    return None


def remote_client(address: str, connect_s: float = CONNECT_S) -> Client:
    """A client of the scheduler at ``address``, reached within ``connect_s`` seconds (Dask's
    ``distributed.comm.timeouts.connect`` is set to it, so a later reconnection gives up as
    soon); ClusterError when it cannot be reached."""
    import dask
    from distributed import Client

    timeout = f"{connect_s}s"
    dask.config.set({"distributed.comm.timeouts.connect": timeout})
    try:
        return Client(address, timeout=timeout)  # type: ignore[no-untyped-call]
    except (OSError, ValueError) as error:   # TimeoutError and CommClosedError are OSErrors
        raise ClusterError(f"cannot be reached within {connect_s:g} s ({reason(error)})",
                           address=address) from None
    except Exception as error:   # something answered, not in Dask's protocol
        raise ClusterError(f"did not answer as a Dask scheduler ({type(error).__name__}: "
                           f"{reason(error)})", address=address) from None


def close_client(client: Client, timeout_s: float = CONNECT_S) -> None:
    """Disconnect (within ``timeout_s`` when the scheduler is gone); a local cluster started
    by :func:`local_client` is shut down too."""
    cluster = getattr(client, "cluster", None)
    with contextlib.suppress(Exception):   # a lost scheduler cannot be told goodbye
        client.close(timeout=timeout_s)  # type: ignore[no-untyped-call]
    if cluster is not None:
        cluster.close()


def silence_dask_logs() -> None:
    """From now on in this process, Dask's loggers print nothing: a lost scheduler makes the
    client log tracebacks (some while the process exits), where ``mapr fleet`` says what
    happened in one line. For a command's process, not a library's caller."""
    for name in ["distributed", *logging.root.manager.loggerDict]:
        if name == "distributed" or name.startswith("distributed."):
            logging.getLogger(name).setLevel(logging.CRITICAL + 1)


def reason(error: BaseException) -> str:
    """An exception's message on one line (Dask's can span several; a cancelled future's
    is its reason alone, e.g. ``scheduler-connection-lost``)."""
    reason = getattr(error, "reason", None)
    text = reason if isinstance(reason, str) else " ".join(str(error).split())
    return text or type(error).__name__
