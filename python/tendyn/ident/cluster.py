"""Dask clients for the commands that spread work over a cluster (``identify``, ``sweep``): one way to connect."""

from __future__ import annotations

__all__ = ["connect_scheduler"]

CONNECT_TIMEOUT = "10s"
"""How long to wait for a scheduler given by address before refusing it."""


def connect_scheduler(address: str):
    """A ``dask.distributed.Client`` on the scheduler at ``address``.

    Raises
    ------
    ConnectionError
        Naming the address when it cannot be reached within :data:`CONNECT_TIMEOUT` (the commands turn it into
        one line, exit 2, before any work).
    """
    from dask.distributed import Client

    try:
        return Client(address, timeout=CONNECT_TIMEOUT)
    except (OSError, TimeoutError, ValueError) as exc:
        raise ConnectionError(f"cannot reach the Dask scheduler at {address!r}: {exc}") from None
