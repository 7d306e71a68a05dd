"""Dask clients for the commands that spread work over a cluster (``identify``, ``sweep``, ``zwidth``, ``design``):
one way to connect, one way to start a local cluster.

The local cluster (:func:`local_cluster`) runs single-threaded worker processes without the memory monitor, the
statistical profiler and Dask's aggressive malloc trimming, with glibc's allocator thresholds of a warm
process (:data:`MMAP_THRESHOLD`), with the event-loop tick probe and the system monitor slowed down. The
campaigns send one batch per worker (or a few), each tens of milliseconds to seconds of CPU, so with Dask's
defaults these periodic samplers cost the workers, and the client process that hosts the scheduler and the
nannies, a large share of the work itself: issue 11 (16 designs, busiest worker 1.59 s → 1.20 s of CPU against
2.0–2.3 s in one process) and issue 32 (8 identifications: client CPU 0.33 s → 0.21 s, docs/cli.md).
"""

from __future__ import annotations

__all__ = ["MMAP_THRESHOLD", "QUIET_CONFIG", "connect_scheduler", "local_cluster", "placement", "worker_threads"]

MMAP_THRESHOLD = 32 * 2**20
"""Bytes: blocks smaller than this come from a worker's heap, never a fresh mapping (glibc's largest dynamic mmap
threshold on 64-bit; a larger value is ignored); the heap is trimmed only beyond twice it."""

QUIET_CONFIG = {"distributed.worker.profile.enabled": False,          # read by the spawned workers
                "distributed.admin.tick.interval": "1000ms",           # event-loop blocking probe (default 20 ms)
                "distributed.admin.system-monitor.interval": "5000ms",  # psutil sampling (default 500 ms)
                # the workers' environment: Dask's default also sets MALLOC_TRIM_THRESHOLD_=65536, with which glibc
                # hands freed memory back to the system at once, so numpy's batch arrays are page-faulted in again
                # at every allocation: +28 % CPU on a design island (2.44 s against 1.91 s in a plain process).
                # Without it glibc's own thresholds start low (mmap and trim 128 kB) and rise only when a large
                # block is freed: a long-running process that once evaluated a large batch (the client, after its
                # pooled evaluation) keeps its heap, a fresh worker trims it after every generation and faults it
                # in again (issue 32: 72 000 page faults, +0.2 s of CPU, per design island; 0 in the warm process).
                # The workers start where a warm process ends: glibc's largest dynamic mmap threshold and twice it
                # for the trim, as glibc sets them itself (MALLOC_MMAP_THRESHOLD_, MALLOC_TRIM_THRESHOLD_).
                "distributed.nanny.pre-spawn-environ": {"OMP_NUM_THREADS": 1, "MKL_NUM_THREADS": 1,
                                                        "OPENBLAS_NUM_THREADS": 1,
                                                        "MALLOC_MMAP_THRESHOLD_": MMAP_THRESHOLD,
                                                        "MALLOC_TRIM_THRESHOLD_": 2 * MMAP_THRESHOLD}}
"""Dask settings of :func:`local_cluster` (module docstring)."""

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


def local_cluster(n_workers: int = 2):
    """A local Dask cluster of ``n_workers`` single-threaded worker processes (no dashboard, no memory monitor,
    no statistical profiler: :data:`QUIET_CONFIG`). Use as a context manager."""
    import dask
    from dask.distributed import LocalCluster

    from tendyn.progress import quiet_dask

    quiet_dask()                                                   # no nanny/worker warnings unless --debug
    with dask.config.set(QUIET_CONFIG):
        return LocalCluster(n_workers=n_workers, threads_per_worker=1, processes=True, memory_limit=0,
                            dashboard_address=None)


def placement(client, n_tasks: int) -> list[dict]:
    """``submit`` keywords that put task k on worker k mod W (W the workers the scheduler knows now), still
    allowed elsewhere if that worker leaves. Without them the scheduler, which knows nothing of a task's cost
    before it ran, measured putting both batches of a 2-worker campaign on the same worker (issue 32: one
    worker 1.63 s of CPU, the other 0.005 s, the campaign then no faster than in one process)."""
    workers = sorted(client.scheduler_info().get("workers", {}))
    if not workers:
        return [{} for _ in range(n_tasks)]
    return [{"workers": [workers[k % len(workers)]], "allow_other_workers": True} for k in range(n_tasks)]


def worker_threads() -> int | None:
    """Threads of the Dask worker running the calling task (1 in :func:`local_cluster`), None outside a worker.
    Compiled kernels that would use every CPU of the machine use this many on a worker: two single-threaded
    workers on two cores each spawning two threads oversubscribe them."""
    try:
        from dask.distributed import get_worker

        return int(get_worker().state.nthreads)
    except (ImportError, ValueError, AttributeError):
        return None
