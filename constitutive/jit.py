"""The one compilation policy of the compiled kernels (numba), and the small pieces the kernels share (Voigt
constants, the exponential-integration helper, the finiteness check). Public: imported by the kernel modules of
constitutive and of fem (``fem._residual_kernel``); importing it imports numba.

``jit(func)`` compiles ``func`` in nopython mode on its first call with
  - ``error_model="numpy"``: floating-point division by zero and invalid operations give inf/nan as in numpy (a
    failed trial is then detected by the kernel and sub-stepped) instead of raising ZeroDivisionError;
  - no fastmath and no parallel loops: results are bit-identical for the same inputs and independent of how many
    points are in a call;
  - ``cache=True``: the machine code is stored next to the source (``__pycache__``) or, where that directory is not
    writable, in numba's user-wide cache directory (``NUMBA_CACHE_DIR`` when set). Processes (forked workers, MPI
    ranks) share that cache; numba writes it atomically. If no cache location is usable, the kernel is compiled
    in memory in every process instead (slower start, same results).
    Numba invalidates a cached function only when its OWN source file changes (a documented numba limitation): the
    helpers and constants of this module, and ``sand.constants.E_MAX_STIFFNESS`` read by ``_simsand_kernel``,
    are frozen into the cached kernels of the other files, and so are the step loops of ``_step_loops``
    into each model's ``drive`` and ``adapt`` (``_mcc_kernel``, ``_anicreep_steps``, ``_swelling_steps``),
    ANICREEP's local solve (``_anicreep_kernel``) into ``_anicreep_points`` and both into ``_anicreep_steps``, and
    the base models' point updates into ``_swelling_steps``. After editing one of them, delete
    the kernels' cache files (``constitutive/__pycache__/*.nbi`` and ``*.nbc``, ``fem/__pycache__/*.nbi`` and
    ``*.nbc``, or those under ``NUMBA_CACHE_DIR``) or touch the kernel modules; otherwise a process keeps running
    the old code.
"""
from __future__ import annotations

import math

import numba

VOIGT_IDENTITY = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)
#: a:b = sum W a b for stress-like Voigt vectors (tensor shear components)
VOIGT_WEIGHTS = (1.0, 1.0, 1.0, 2.0, 2.0, 2.0)
#: engineering-strain deviator -> 2 x tensor deviator
STRAIN_TO_TENSOR = (2.0, 2.0, 2.0, 1.0, 1.0, 1.0)


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


@jit
def expm1_over_x(x):
    """phi(x) = (exp(x) - 1)/x and phi'(x) (exact integration of p' along a volumetric elastic strain increment);
    series sum_k x^k/(k+1)! (k <= 6) for |x| < 1e-2 (error < 4e-16)."""
    if abs(x) < 1e-2:
        phi = 1.0 + x * (1 / 2 + x * (1 / 6 + x * (1 / 24 + x * (1 / 120 + x * (1 / 720 + x / 5040)))))
        dphi = 1 / 2 + x * (2 / 6 + x * (3 / 24 + x * (4 / 120 + x * (5 / 720 + x * 6 / 5040))))
        return phi, dphi
    return math.expm1(x) / x, (math.exp(x) * (x - 1.0) + 1.0) / (x * x)


@jit
def all_finite(a):
    """True when every entry of the array ``a`` is finite (stops at the first that is not)."""
    for v in a.flat:
        if not math.isfinite(v):
            return False
    return True


@jit(inline="always")
def next_substep(pos, level, units):
    """Depth-first bisection of an increment into ``units`` = 2^max_depth slots: after an accepted sub-step of size
    units >> level at slot ``pos``, the next slot and level (climb a level each time both halves are done)."""
    pos += units >> level
    while level > 0 and pos % (units >> (level - 1)) == 0:
        level -= 1
    return pos, level
