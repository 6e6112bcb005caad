"""ANICREEP's update of one point in the form of the compiled step loops (:mod:`constitutive._step_loops`), and
the loops with it (``drive``: ``mixed_control``, ``adapt``: ``adaptive_control``); the integration is
:mod:`constitutive._anicreep_points`' ``_update_point_lab``, inlined. Compression positive, kPa, s.
"""
from __future__ import annotations

import numpy as np

from ._anicreep_kernel import LOCAL_NEWTON_FAILED, PARAMETER_COLUMNS, VOID_RATIO_COLLAPSED
from ._anicreep_points import _scratch, _update_point_lab
from ._step_loops import adapt_points, drive_points
from .jit import jit

#: the columns of the state of :func:`point_update`
STATE_COLUMNS = (("alpha", 6), ("pm_ref", 1), ("void_ratio", 1), ("vp_strain", 6), ("vp_shear", 1),
                 ("overstress", 1), ("chi", 1))
#: the columns of PARAMETER_COLUMNS proportional to the specific volume v (c_e, c_p, omega) and to 1/v (mu)
VOLUME_COLUMNS, INVERSE_VOLUME_COLUMN = (1, 2, 4), 7


@jit
def point_update(stress, state, deps, dt, prm, settings, stress_out, state_out, tangent_out, info, work):
    """The model's update of one point in the form of the compiled step loop
    (``_step_loops.drive_points``), as ``ANICREEP.update``: ``state`` (17,) in STATE_COLUMNS; ``prm``
    PARAMETER_COLUMNS then v0 = 1 + e0, where ``settings[0]`` (the current specific volume) with the VOLUME_COLUMNS
    (and, viscous, the INVERSE_VOLUME_COLUMN) at v = 1, multiplied (divided) by v = 1 + e_n here; settings: (current
    specific volume, viscous, tol, max_it, max_dz, max_depth, reduce) as numbers. The void ratio moves by
    -v d eps_v. Returns 0, or LOCAL_NEWTON_FAILED with ``info`` (dt, stress (6)), or VOID_RATIO_COLLAPSED with
    ``info`` (the new and the old void ratio)."""
    row = work[13]
    viscous = settings[1] != 0.0
    e = state[7]
    for k in range(row.size):
        row[k] = prm[k]
    if settings[0] != 0.0:
        v = 1.0 + e
        for k in VOLUME_COLUMNS:
            row[k] = prm[k] * v
        if viscous:
            row[INVERSE_VOLUME_COLUMN] = prm[INVERSE_VOLUME_COLUMN] / v
    else:
        v = prm[row.size]
    ok, pm, chi, ratio, vp_shear = _update_point_lab(
        stress, state[0:6], state[6], state[16], deps, dt, row, viscous, settings[2], int(settings[3]), settings[4],
        int(settings[5]), settings[6] != 0.0, True, stress_out, state_out[0:6], state_out[8:14], tangent_out,
        work[:13])
    if not ok:
        info[0] = dt
        for k in range(6):
            info[1 + k] = stress[k]
        return LOCAL_NEWTON_FAILED
    e_new = e - v * (deps[0] + deps[1] + deps[2])
    if e_new <= 0.0:
        info[0], info[1] = e_new, e
        return VOID_RATIO_COLLAPSED
    state_out[6] = pm
    state_out[7] = e_new
    for k in range(6):
        state_out[8 + k] += state[8 + k]
    state_out[14] = state[14] + vp_shear
    state_out[15] = ratio
    state_out[16] = chi
    return 0


@jit
def drive(prm, settings, stress0, state0, steps, stop, newton, history, ending):
    """``_step_loops.drive_points`` with :func:`point_update` (the arguments are its)."""
    return drive_points(point_update, prm, settings, (*_scratch(), np.zeros(len(PARAMETER_COLUMNS))), 7, stress0,
                        state0, steps, stop, newton, history, ending)


@jit
def adapt(prm, settings, stress0, state0, control, undrained, path, segments, records, going, step_control, newton,
          history, ending):
    """``_step_loops.adapt_points`` with :func:`point_update` (the arguments are its)."""
    return adapt_points(point_update, prm, settings, (*_scratch(), np.zeros(len(PARAMETER_COLUMNS))), 7, stress0,
                        state0, control, undrained, path, segments, records, going, step_control, newton, history,
                        ending)
