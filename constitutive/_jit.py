"""The one compilation policy of the constitutive kernels (numba), imported only by the kernel modules.

``jit(func)`` compiles ``func`` in nopython mode on its first call with
  - ``error_model="numpy"``: floating-point division by zero and invalid operations give inf/nan as in numpy (a
    failed trial is then detected by the kernel and sub-stepped) instead of raising ZeroDivisionError;
  - no fastmath and no parallel loops: results are bit-identical for the same inputs and independent of how many
    points are in a call;
  - ``cache=True``: the machine code is stored next to the source (``__pycache__``) or, where that directory is not
    writable, in numba's user-wide cache directory (``NUMBA_CACHE_DIR`` when set). Processes (forked workers, MPI
    ranks) share that cache; numba writes it atomically. If no cache location is usable, the kernel is compiled
    in memory in every process instead (slower start, same results).
"""
from __future__ import annotations

import numba


def jit(func=None, *, inline="never"):
    """``numba.njit`` with the policy of the module docstring; ``@jit`` or ``@jit(inline="always")`` (numba-IR
    inlining into the caller: one compiled body instead of a separately optimized library, which roughly halves
    the compile time of a large function called from one place)."""
    if func is None:
        return lambda f: jit(f, inline=inline)
    try:
        return numba.njit(cache=True, error_model="numpy", inline=inline)(func)
    except RuntimeError:  # no writable cache location ("cannot cache function ...: no locator available")
        return numba.njit(cache=False, error_model="numpy", inline=inline)(func)
