"""Per-point covariates of a programme of tests for the diagnosis' attribution (names from
``constitutive.physics_catalog.COVARIATES``), in the form ``inference.diagnosis`` takes: {name: {(test, curve): array
aligned with the recorded points, or a scalar for a condition of the test}}.

Along a curve: time since the start of the test (s), strain level |eps| (-), and the MAP simulation's stress ratio
q/p' and mean effective stress p' (kPa). Between tests (conditions): strain rate (1/s), loading phase (load or hold),
stress path direction, consolidation and, for a model with a critical state line, the initial state parameter
psi_0 = e_0 - e_c(p'_0) of the MAP. A between-test covariate is kept only when it takes at least two values.
Further covariates of particular programmes: :func:`post_peak_strain`,
:func:`drainage_time_factor`.
"""
from __future__ import annotations

import numpy as np

from fem.oracles import consolidation_coefficient

__all__ = ["programme_covariates", "BETWEEN", "post_peak_strain", "drainage_time_factor"]

ALONG = ("time", "strain level", "stress ratio", "mean effective stress")
BETWEEN = ("strain rate", "loading phase", "stress path direction", "consolidation", "initial state parameter")
ORDER = ("strain rate", "time", "strain level", "stress ratio", "mean effective stress", "loading phase",
         "stress path direction", "consolidation", "initial state parameter")


def programme_covariates(tests, observations, map_curves: dict, strains=None, times=None) -> dict:
    """Covariates of every recorded curve of the ``tests`` (TestSpec) from the base class's MAP curves
    ``map_curves`` {test: {quantity: values}} (``stress_ratio``, ``mean_stress``, ``initial_state_parameter`` and,
    for an incremental oedometer, ``axial_strain`` in %, where the forward model reports them).

    strains: {test: axial or cavity strains (-) of the records} (default: the recorded abscissae in % / 100); times:
    {test: record times (s) or None} (default: strain / strain rate; an incremental oedometer's abscissa is its
    time)."""
    strains, times = strains or {}, times or {}
    cov = {k: {} for k in ORDER}
    for spec in tests:
        test = observations[spec.name]
        sim = map_curves[spec.name]
        for c, curve in test.curves.items():
            k = (spec.name, c)
            if spec.type == "oedometer_creep":
                cov["time"][k] = curve.x
                cov["strain level"][k] = np.abs(np.asarray(sim["axial_strain"])) / 100.0
            else:
                level = np.abs(strains[spec.name]) if spec.name in strains else np.abs(curve.x) / 100.0
                cov["strain rate"][k] = spec.strain_rate
                cov["strain level"][k] = level
                recorded = times.get(spec.name)
                cov["time"][k] = recorded if recorded is not None else level / spec.strain_rate
            if "stress_ratio" in sim:
                cov["stress ratio"][k] = np.asarray(sim["stress_ratio"])
                cov["mean effective stress"][k] = np.asarray(sim["mean_stress"])
            if "initial_state_parameter" in sim:
                cov["initial state parameter"][k] = float(sim["initial_state_parameter"][0])
            cov["loading phase"][k] = "hold" if spec.type == "oedometer_creep" else "load"
            if spec.type == "triaxial":
                cov["stress path direction"][k] = spec.direction
                cov["consolidation"][k] = spec.consolidation
    return {k: v for k, v in cov.items() if v and (k not in BETWEEN or len({str(x) for x in v.values()}) > 1)}


def post_peak_strain(strain, deviator):
    """|strain| beyond the strain of the largest recorded |q| (``deviator``), NaN up to that point (and everywhere
    when the record peaks at its last point): the covariate is defined on the softening branch only."""
    k = int(np.argmax(deviator))
    return np.where(np.arange(strain.size) > k, strain - strain[k], np.nan)


def drainage_time_factor(time, permeability: float, shear_modulus: float, nu: float, a0: float):
    """T = c_h t / a0^2 of a cavity expansion (Randolph & Wroth's c_h from the permeability k (m/s), the elastic
    shear modulus G (kPa) and Poisson's ratio; ``fem.oracles.consolidation_coefficient``); t in s, a0 in m."""
    return consolidation_coefficient(permeability, shear_modulus, nu) * time / a0 ** 2
