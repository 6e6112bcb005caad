"""Laboratory-test drivers for any material-point model, vectorized over points (a batch of particles).

One generic mixed-control driver, :func:`mixed_control`: at every step each of the 6 Voigt components has either a
prescribed strain increment or a prescribed stress increment, and optionally the step is undrained (volume held
constant, an excess pore pressure increment du added to the unknowns, the prescribed stresses then being *total*
stresses: sigma = sigma' + u 1). The unknown strain components (and du) are found by Newton iterations using the
model's tangent; a point whose Newton fails raises IntegrationError (or is frozen with NaN curves when
``on_failure="nan"``, for batched calibration). Points iterate independently (a point stops iterating when it has
converged), so a batched run equals the individual runs to round-off.

The named drivers are thin wrappers that build the control table and return named curves, each an array of shape
(n_particles, n_points) at the requested points:

    curves = drained_triaxial(model, e0, p0, axial_strain)           # constant radial stress, axial strain control
    curves = undrained_triaxial(model, e0, p0, axial_strain)         # constant total radial stress, isochoric
    curves = isotropic_compression(model, e0, p0, p)                 # p' path, drained
    curves = oedometer_crs(model, e0, sigma_v0, axial_strain, strain_rate)     # lateral strain zero, real time
    curves = oedometer_loading(model, e0, sigma_v0, sigma_v, stage_duration)   # load stages held with creep
    curves = triaxial_stages(model, e0, p0, stages)                  # shear / creep / relaxation stages

Curves: ``axial_strain``, ``radial_strain``, ``volumetric_strain`` (dimensionless, compression positive), ``q``
(= sigma'_a - sigma'_r, signed, kPa), ``p`` (p', kPa), ``e`` (void ratio), ``excess_pore_pressure`` (kPa),
``time`` (s), ``axial_stress``, ``radial_stress`` (effective, kPa), ``total_axial_stress``, ``total_radial_stress``,
``failed`` (n,) bool. Axial is Voigt component 11, radial the mean of 22 and 33.

Routing of the triaxial drivers (``route``): a model with its own batched triaxial integrator
``model.triaxial_test(e0, p0, axial_strain, drained=..., substeps=..., on_failure=...)`` (SIMSAND) is run through it
(``route="auto"``, the default, when the request fits it: isotropic start k0 = 1 and one strain list for all
points), so a study has one route and one failure rule for all particles; the curves get the same names (``time``
and the total stresses are added here). ``route="generic"`` asks for :func:`mixed_control` explicitly (e.g. to
verify the fast path), ``route="fast"`` insists on the model's own integrator (an error if it cannot serve).

Batching: a model whose parameters are arrays of shape (n,), with e0 and p0 scalars or (n,), runs in one call.
``model`` is any object with ``initial_state(stress0, void_ratio0)`` and ``update(stress, state, dstrain, dt)``
(constitutive.base); the state must contain ``void_ratio``.
"""
from __future__ import annotations

import numpy as np

from .mixed_control import NORMAL, LinearPath, adaptive_control, batch_size, mixed_control

__all__ = ["mixed_control", "adaptive_control", "LinearPath", "NORMAL", "drained_triaxial", "undrained_triaxial",
           "isotropic_compression", "oedometer_crs", "oedometer_loading", "triaxial_stages", "batch_size"]

#: control rows: True = strain increment prescribed
AXIAL_STRAIN_CONTROL = np.array([True, False, False, True, True, True])   # triaxial, radial stresses prescribed
ALL_STRAIN = np.ones(6, dtype=bool)
NORMAL_STRESS = np.array([False, False, False, True, True, True])         # isotropic / triaxial creep
OEDOMETER_STRESS = np.array([False, True, True, True, True, True])        # axial stress, lateral strain zero


def _curves(hist):
    """Named triaxial/oedometer curves (axial = 11, radial = mean of 22 and 33) from a mixed_control history."""
    s, eps, u = hist["stress"], hist["strain"], hist["pore_pressure"]
    axial, radial = s[..., 0], 0.5 * (s[..., 1] + s[..., 2])
    return {
        "axial_strain": eps[..., 0],
        "radial_strain": 0.5 * (eps[..., 1] + eps[..., 2]),
        "volumetric_strain": eps[..., :3].sum(axis=-1),
        "q": axial - radial,
        "p": s[..., :3].mean(axis=-1),
        "e": hist["void_ratio"],
        "excess_pore_pressure": u,
        "time": hist["time"],
        "axial_stress": axial,
        "radial_stress": radial,
        "total_axial_stress": axial + u,
        "total_radial_stress": radial + u,
        "failed": hist["failed"],
    }


def _start(model, e0, sigma_a0, sigma_r0, n):
    stress0 = np.zeros((n, 6))
    stress0[:, 0] = sigma_a0
    stress0[:, 1] = stress0[:, 2] = sigma_r0
    return stress0, model.initial_state(stress0, np.broadcast_to(np.asarray(e0, dtype=float), (n,)))


def _isotropic_start(model, e0, p0, k0, n):
    """Initial stress with mean p0 and sigma'_r/sigma'_a = k0."""
    p0 = np.broadcast_to(np.asarray(p0, dtype=float), (n,))
    sigma_a0 = 3.0 * p0 / (1.0 + 2.0 * k0)
    return _start(model, e0, sigma_a0, k0 * sigma_a0, n)


def _path_steps(targets, substeps):
    """Increments reaching each target of ``targets`` (last axis) in ``substeps`` equal steps from 0, and the record
    mask. targets (n_points,) or (n, n_points); returns increments (n_steps,) or (n_steps, n)."""
    targets = np.asarray(targets, dtype=float)
    start = np.zeros(targets.shape[:-1] + (1,))
    d = np.diff(np.concatenate([start, targets], axis=-1), axis=-1) / substeps
    d = np.repeat(np.moveaxis(d, -1, 0), substeps, axis=0)
    record = np.zeros(d.shape[0], dtype=bool)
    record[substeps - 1::substeps] = True
    return d, record


def _drop_initial(curves):
    """Drop the initial record (the drivers return curves at the requested points only)."""
    return {k: (v if k == "failed" else v[:, 1:]) for k, v in curves.items()}


ROUTES = ("auto", "fast", "generic")


def _fast_route(model, axial_strain, k0, route) -> bool:
    """Whether a triaxial request goes to ``model.triaxial_test`` (see the module docstring, "Routing")."""
    if route not in ROUTES:
        raise ValueError(f"route must be one of {ROUTES}, got {route!r}")
    if route == "generic":
        return False
    reasons = []
    if not callable(getattr(model, "triaxial_test", None)):
        reasons.append(f"model {type(model).__name__} has no triaxial_test method")
    if k0 != 1.0:
        reasons.append(f"k0 = {k0:g} (the fast path starts from an isotropic state)")
    if np.ndim(axial_strain) != 1:
        reasons.append(f"axial_strain of shape {np.shape(axial_strain)} (the fast path takes one list for all points)")
    if reasons and route == "fast":
        raise ValueError("route='fast' is not possible: " + "; ".join(reasons))
    return not reasons


def _fast_triaxial(model, e0, p0, axial_strain, undrained, substeps, strain_rate, on_failure, n):
    """The model's own triaxial integrator, with the curves of :func:`_curves` it does not return."""
    e0 = np.broadcast_to(np.asarray(e0, dtype=float), (n,))
    p0 = np.broadcast_to(np.asarray(p0, dtype=float), (n,))
    c = dict(model.triaxial_test(e0, p0, axial_strain, drained=not undrained, substeps=substeps,
                                 on_failure=on_failure))
    targets = np.asarray(axial_strain, dtype=float)
    time = np.cumsum(np.abs(np.diff(np.concatenate([[0.0], targets])))) / strain_rate
    c["time"] = np.where(np.isnan(c["q"]), np.nan, time)
    c["total_axial_stress"] = c["axial_stress"] + c["excess_pore_pressure"]
    c["total_radial_stress"] = c["radial_stress"] + c["excess_pore_pressure"]
    return c


def _triaxial(model, e0, p0, axial_strain, undrained, k0, substeps, strain_rate, on_failure, route):
    n = batch_size(model, e0, p0, axial_strain if np.ndim(axial_strain) == 2 else None)
    if on_failure not in ("raise", "nan"):
        raise ValueError(f"on_failure must be 'raise' or 'nan', got {on_failure!r}")
    if _fast_route(model, axial_strain, k0, route):
        return _fast_triaxial(model, e0, p0, axial_strain, undrained, substeps, strain_rate, on_failure, n)
    stress0, state0 = _isotropic_start(model, e0, p0, k0, n)
    d, record = _path_steps(axial_strain, substeps)
    inc = np.zeros(d.shape[:1] + (n, 6))
    inc[:, :, 0] = d if d.ndim == 2 else d[:, None]  # radial (total) stress increments stay zero
    dt = np.abs(inc[:, :, 0]).max(axis=1) / strain_rate
    hist = mixed_control(model, stress0, state0, AXIAL_STRAIN_CONTROL, inc, dt, undrained=undrained, record=record,
                         on_failure=on_failure)
    return _drop_initial(_curves(hist))


def drained_triaxial(model, e0, p0, axial_strain, *, k0=1.0, substeps=1, strain_rate=1e-5, on_failure="raise",
                     route="auto"):
    """Drained triaxial compression (or extension for decreasing axial strain): constant radial effective stress,
    axial strain control. e0 void ratio, p0 initial p' (kPa), scalars or (n,); axial_strain (n_points,) or
    (n, n_points) the requested strains (dimensionless, from 0), each interval split in ``substeps`` steps;
    k0 = sigma'_r0/sigma'_a0 of the initial stress; strain_rate (1/s) sets the time; route "auto" | "fast" |
    "generic" (module docstring, "Routing"). Returns the named curves."""
    return _triaxial(model, e0, p0, axial_strain, False, k0, substeps, strain_rate, on_failure, route)


def undrained_triaxial(model, e0, p0, axial_strain, *, k0=1.0, substeps=1, strain_rate=1e-5, on_failure="raise",
                       route="auto"):
    """Undrained triaxial: constant total radial stress, no volume change, axial strain control; the curve
    ``excess_pore_pressure`` is u - u0 (kPa). Arguments as :func:`drained_triaxial`."""
    return _triaxial(model, e0, p0, axial_strain, True, k0, substeps, strain_rate, on_failure, route)


def isotropic_compression(model, e0, p0, p, *, substeps=1, rate=1e-2, on_failure="raise"):
    """Drained isotropic compression/swelling from p0 through the requested mean effective stresses ``p`` (kPa,
    (n_points,) or (n, n_points)); ``rate`` dp'/dt in kPa/s sets the time."""
    n = batch_size(model, e0, p0, p if np.ndim(p) == 2 else None)
    p0 = np.broadcast_to(np.asarray(p0, dtype=float), (n,))
    stress0, state0 = _isotropic_start(model, e0, p0, 1.0, n)
    p = np.asarray(p, dtype=float)
    d, record = _path_steps(p - p0[:, None], substeps)  # (n_steps, n)
    inc = np.zeros(d.shape[:1] + (n, 6))
    inc[:, :, :3] = d[..., None]
    dt = np.abs(inc[:, :, 0]).max(axis=1) / rate
    hist = mixed_control(model, stress0, state0, NORMAL_STRESS, inc, dt, record=record, on_failure=on_failure)
    return _drop_initial(_curves(hist))


def oedometer_crs(model, e0, sigma_v0, axial_strain, strain_rate, *, k0=1.0, substeps=1, on_failure="raise"):
    """Constant-rate-of-strain oedometer (lateral strain zero, drained): axial strain to the requested values at
    ``strain_rate`` (1/s, real time dt = d eps_a/rate). Initial sigma'_v0 (kPa) with sigma'_h0 = k0 sigma'_v0."""
    n = batch_size(model, e0, sigma_v0, axial_strain if np.ndim(axial_strain) == 2 else None)
    sigma_v0 = np.broadcast_to(np.asarray(sigma_v0, dtype=float), (n,))
    stress0, state0 = _start(model, e0, sigma_v0, k0 * sigma_v0, n)
    d, record = _path_steps(axial_strain, substeps)
    inc = np.zeros(d.shape[:1] + (n, 6))
    inc[:, :, 0] = d if d.ndim == 2 else d[:, None]
    dt = np.abs(inc[:, :, 0]).max(axis=1) / strain_rate
    hist = mixed_control(model, stress0, state0, ALL_STRAIN, inc, dt, record=record, on_failure=on_failure)
    return _drop_initial(_curves(hist))


def _log_times(duration, first, n_times):
    """n_times log-spaced times from ``first`` to ``duration`` (s)."""
    return np.geomspace(first, duration, n_times)


def oedometer_loading(model, e0, sigma_v0, sigma_v, stage_duration=86400.0, *, n_times=20, load_time=1.0,
                      load_substeps=1, substeps=1, k0=1.0, on_failure="raise"):
    """Incremental oedometer (lateral strain zero, drained): each stage ramps sigma'_v to the next value of
    ``sigma_v`` (kPa) in ``load_time`` s, then holds it until ``stage_duration`` s after the stage start, curves
    recorded at ``n_times`` log-spaced times (from load_time). Extra curves: ``stage`` (index) and ``stage_time``
    (time since the stage start, s). Shapes (n, n_stages * n_times)."""
    n = batch_size(model, e0, sigma_v0)
    sigma_v0 = np.broadcast_to(np.asarray(sigma_v0, dtype=float), (n,))
    stress0, state0 = _start(model, e0, sigma_v0, k0 * sigma_v0, n)
    levels = np.atleast_1d(np.asarray(sigma_v, dtype=float))
    hold_times = _log_times(stage_duration, load_time, n_times)
    dts, incs, records, stage_time, stage = [], [], [], [], []
    previous = sigma_v0
    for i, level in enumerate(levels):
        ramp = (level - previous) / load_substeps
        previous = np.full(n, level)
        dts += [load_time / load_substeps] * load_substeps
        incs += [ramp] * load_substeps
        records += [False] * (load_substeps - 1) + [True]
        for dt_hold in np.diff(hold_times):
            dts += [dt_hold / substeps] * substeps
            incs += [np.zeros(n)] * substeps
            records += [False] * (substeps - 1) + [True]
        stage_time.append(hold_times)
        stage.append(np.full(n_times, i))
    inc = np.zeros((len(dts), n, 6))
    inc[:, :, 0] = np.array(incs)
    hist = mixed_control(model, stress0, state0, OEDOMETER_STRESS, inc, np.array(dts), record=np.array(records),
                         on_failure=on_failure)
    curves = _drop_initial(_curves(hist))
    curves["stage"] = np.broadcast_to(np.concatenate(stage), (n, n_times * levels.size)).copy()
    curves["stage_time"] = np.broadcast_to(np.concatenate(stage_time), curves["stage"].shape).copy()
    return curves


def triaxial_stages(model, e0, p0, stages, *, k0=1.0, drained=True, on_failure="raise"):
    """A sequence of triaxial stages (constant radial total stress throughout), each a dict:

    - ``{"type": "shear", "axial_strain": [...], "strain_rate": 1e-5, "substeps": 1}``: axial strain control to the
      requested strains (measured from the start of the test);
    - ``{"type": "creep", "duration": s, "n_times": 20, "first": 1.0, "substeps": 1}``: axial stress held, time
      advancing to ``duration`` after the stage start, records at log-spaced times from ``first``;
    - ``{"type": "relaxation", ...}``: as creep, with the axial strain held instead.
    ``drained``: True for all stages drained, False for all undrained. Extra curve ``stage`` (index per record)."""
    n = batch_size(model, e0, p0)
    stress0, state0 = _isotropic_start(model, e0, p0, k0, n)
    control, incs, dts, records, stage_of = [], [], [], [], []
    eps_a = 0.0
    for i, st in enumerate(stages):
        kind = st.get("type")
        sub = int(st.get("substeps", 1))
        if kind == "shear":
            targets = np.asarray(st["axial_strain"], dtype=float)
            d, rec = _path_steps(targets - eps_a, sub)
            eps_a = targets[-1]
            control += [AXIAL_STRAIN_CONTROL] * d.size
            incs += [np.array([x, 0, 0, 0, 0, 0]) for x in d]
            dts += list(np.abs(d) / st.get("strain_rate", 1e-5))
        elif kind in ("creep", "relaxation"):
            times = _log_times(st["duration"], st.get("first", 1.0), int(st.get("n_times", 20)))
            steps = np.repeat(np.diff(np.concatenate([[0.0], times])) / sub, sub)
            rec = np.zeros(steps.size, dtype=bool)
            rec[sub - 1::sub] = True
            ctrl = NORMAL_STRESS if kind == "creep" else AXIAL_STRAIN_CONTROL
            control += [ctrl] * steps.size
            incs += [np.zeros(6)] * steps.size
            dts += list(steps)
        else:
            raise ValueError(f"stage {i}: type must be 'shear', 'creep' or 'relaxation', got {kind!r}")
        records += list(rec)
        stage_of += [i] * int(np.sum(rec))
    hist = mixed_control(model, stress0, state0, np.array(control), np.array(incs), np.array(dts),
                         undrained=not drained, record=np.array(records), on_failure=on_failure)
    curves = _drop_initial(_curves(hist))
    curves["stage"] = np.broadcast_to(np.array(stage_of), curves["q"].shape).copy()
    return curves
