"""Imported first (before numpy and numba) by the benchmarks that time threads: numba's pool holds all
usable cores unless the caller set ``NUMBA_NUM_THREADS`` (numba reads it once, at import), and BLAS and
OpenMP libraries run one thread each unless set."""

import os

try:
    os.environ.setdefault("NUMBA_NUM_THREADS", str(len(os.sched_getaffinity(0))))
except AttributeError:  # not on Linux
    pass
for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
