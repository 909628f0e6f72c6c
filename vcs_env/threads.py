"""Threads of the simulator's kernels: each kernel compiled twice, serial and over worlds in parallel.

The step's kernels (:mod:`vcs_env.kernels`, its wall and stop kernels, the obstacle motion
kernels), the observation kernel and the lidar loop over worlds, then robots, and a world's
iteration writes only that world's outputs: no reduction runs across worlds. So the world loop
is a numba ``prange`` and the results are bit-identical for any thread count.

Each kernel is one Python source compiled twice by :func:`twin_kernel`: a serial dispatcher
(``prange`` is ``range`` there: today's code) and a ``parallel=True`` one. Numba's on-disk cache
keys a dispatcher on the function's qualified name and first source line, not on its flags, so
two dispatchers of one function share (and load each other's) cache entries; the parallel twin
is therefore a copy of the function under the name ``<name>_parallel`` (its own cache files).

Threading layer: numba's choice (GNU OpenMP, ``omp``, where present; ``NUMBA_THREADING_LAYER``
picks another). Known hazard, not worked around: with ``omp`` every ``fork()`` child of a process
that has already run a parallel kernel aborts ("fork() called from a process already using GNU
OpenMP, this is unsafe"; a forked multiprocessing pool then hangs). Fork before the first batched
step, use the ``spawn``/``forkserver`` start methods, keep the parent on :func:`set_threads` ``(1)``
from the start (its kernels then never start OpenMP), or set ``NUMBA_THREADING_LAYER=workqueue``
(fork-safe, but on the 2-core test machine it ran no faster on 2 threads than on 1) or ``tbb``
(``pip install tbb``; fork- and thread-safe, not measured).

The thread count is process-wide (numba's thread pool is): :func:`set_threads` (default: the
cores this process may use, capped by ``NUMBA_NUM_THREADS``, which numba reads at import). A
call runs the serial twin when the count is 1 or the batch has fewer than
:data:`MIN_PARALLEL_BATCH` worlds, or than a kernel's own smaller ``min_batch`` (the VCS planner's:
16; B = 1 envs pay nothing for threads).
"""

from __future__ import annotations

import os
import types

import numba
import numpy as np
from numba import njit

MIN_PARALLEL_BATCH = int(os.environ.get("VCS_ENV_MIN_PARALLEL_BATCH", "128"))
"""Smallest batch ``B`` [worlds] stepped by the parallel twins; below it the serial ones run
(thread start-up costs more than it saves: at ``n = 3``, 2 threads break even near ``B = 128``,
``benchmarks/THREADS.md``).
The environment variable ``VCS_ENV_MIN_PARALLEL_BATCH`` sets it at import (1: the parallel twins
at every ``B``, e.g. to run the determinism tests through them)."""


def available_cores() -> int:
    """Cores this process may run on (its CPU affinity)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def max_threads() -> int:
    """Largest thread count: numba's pool size ``NUMBA_NUM_THREADS`` (fixed at numba's import)."""
    return int(numba.config.NUMBA_NUM_THREADS)


_threads = [max(1, min(available_cores(), max_threads()))]


def set_threads(n: int | None = None) -> int:
    """Threads of the kernels from now on, for the whole process (numba's pool is process-wide);
    ``None``: :func:`available_cores` capped by :func:`max_threads`. 1 runs every kernel serially.
    Results do not depend on it. Returns the count set."""
    limit = max_threads()
    if n is None:
        n = max(1, min(available_cores(), limit))
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or not 1 <= n <= limit:
        raise ValueError(f"set_threads(n): n must be an integer in [1, {limit}] (NUMBA_NUM_THREADS={limit}), got {n!r}")
    _threads[0] = int(n)  # numpy integers too, as seeds and step limits
    return int(n)


def get_threads() -> int:
    """The thread count of :func:`set_threads`."""
    return _threads[0]


class TwinKernel:
    """A kernel compiled serial (``.serial``) and parallel over worlds (``.parallel``); calling it
    runs one of them (module docstring). The first argument's leading axis is the batch ``B`` (of its
    first field, for a tuple of arrays such as the VCS planner's world)."""

    def __init__(self, func, min_batch: int | None = None, **options):
        self.min_batch = min_batch  # smallest batch run in parallel (None: MIN_PARALLEL_BATCH; never above it)
        self.__wrapped__ = func
        self.__doc__, self.__name__, self.__qualname__ = func.__doc__, func.__name__, func.__qualname__
        self.__module__ = func.__module__
        self.serial = njit(**options)(func)
        twin = types.FunctionType(func.__code__, func.__globals__, func.__name__ + "_parallel", func.__defaults__)
        twin.__qualname__ = func.__qualname__ + "_parallel"  # its own cache files
        twin.__module__, twin.__doc__ = func.__module__, func.__doc__
        self.parallel = njit(parallel=True, **options)(twin)

    def __call__(self, *args):
        n = _threads[0]
        lead = args[0] if hasattr(args[0], "shape") else args[0][0]  # an array, or a tuple of arrays
        limit = MIN_PARALLEL_BATCH if self.min_batch is None else min(self.min_batch, MIN_PARALLEL_BATCH)
        if n > 1 and lead.shape[0] >= limit:
            if numba.get_num_threads() != n:
                numba.set_num_threads(n)
            return self.parallel(*args)
        return self.serial(*args)


def twin_kernel(min_batch: int | None = None, **options):
    """Decorator: :class:`TwinKernel` with numba ``options`` (e.g. ``cache=True``); ``min_batch``: the
    smallest batch it runs in parallel, for a kernel with more work per world than the step's."""
    return lambda func: TwinKernel(func, min_batch=min_batch, **options)


WORLD_BLOCK = 16
"""Worlds per block of the kernels that keep per-world scratch arrays: one allocation per block."""
