"""Worker threads for batches of simulated runs: how many, and the shared progress count.

Why threads, not processes: the plant's per-step work is one compiled kernel that releases
the GIL (:mod:`drivers.jit`), and most of the feature extraction is numpy array passes, which
release it too; threads share the actuator parameters and the kernels already loaded, where
processes would each load numba and copy their inputs and results.

Why a bound on the work in flight: a dictionary build flies some 1,500 runs, and the raw
channels of all of them at once are half a gigabyte; a pool that takes a task per worker and
returns each result as it lands keeps only ``workers`` batches of raw channels alive.
"""

from __future__ import annotations

import os
import threading
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ThreadPoolExecutor, wait
from typing import TypeVar

from mapr_daemon.errors import ConfigError

T = TypeVar("T")
R = TypeVar("R")


def usable_cores() -> int:
    """The cores this process may run on (its CPU affinity, which a container or ``taskset``
    narrows), not the machine's count."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


def resolve(workers: int | None) -> int:
    """``workers`` checked (>= 1), or :func:`usable_cores` when ``None``."""
    if workers is None:
        return usable_cores()
    if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
        raise ConfigError(f"workers must be a whole number >= 1 (got {workers!r})",
                          field="workers")
    return workers


def unordered(function: Callable[[T], R], items: Iterable[T], workers: int) -> Iterator[R]:
    """``function(item)`` for every item on ``workers`` threads, each result as it lands.

    At most ``workers`` items are in flight (an item is handed out when a worker frees), so
    the results not yet taken by the caller are bounded too. The first exception of any item
    is raised here after the items in flight finish; the ones not yet started never start.
    With one worker everything runs on the calling thread, in order.
    """
    if workers == 1:
        for item in items:
            yield function(item)
        return
    todo = iter(items)
    with ThreadPoolExecutor(max_workers=workers, thread_name_prefix="mapr-batch") as pool:
        running: set[Future[R]] = set()

        def refill() -> None:
            for item in todo:
                running.add(pool.submit(function, item))
                if len(running) >= workers:
                    return

        refill()
        while running:
            done, _ = wait(running, return_when=FIRST_COMPLETED)
            for future in done:
                running.discard(future)
                result = future.result()   # raises the item's exception; the with waits
                yield result
                del result
            refill()


class Progress:
    """A fraction of work done, reported monotonically to a callback from any thread.

    Each :meth:`add` adds its units under a lock and calls the callback with the new fraction
    while still holding it, so the calls are serialised and never go backwards; the last unit
    reports exactly 1.0.
    """

    def __init__(self, total: int, callback: Callable[[float], None] | None) -> None:
        self.total = max(int(total), 1)
        self.done = 0
        self.callback = callback
        self._lock = threading.Lock()

    def add(self, units: int) -> None:
        if self.callback is None:
            return
        with self._lock:
            self.done = min(self.total, self.done + int(units))
            self.callback(self.done / self.total)
