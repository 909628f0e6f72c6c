"""``python -m benchmarks``: see :mod:`benchmarks.run`."""

import os
import sys

# One thread everywhere (set before numpy and torch load their thread pools): rates are per CPU
# second, and every contestant gets one core.
for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(var, "1")

from .run import main  # noqa: E402

sys.exit(main())
