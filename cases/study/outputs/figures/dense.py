"""The MAP's curves between the records: the forward model asked for every curve at abscissae ``factor`` times
denser than the recorded ones (linear between consecutive records, over each stage's recorded span), so that a
figure draws the model as a continuous line rather than straight segments between the records; and for p' beside
every recorded q, so that the stress paths of the stages of a programme can be drawn."""
from __future__ import annotations

import numpy as np

from cases.study.programme import split_key
from inference.observations import Curve, Observations, Test

__all__ = ["densified", "with_mean_stress", "dense_curves"]


def densified(observations, factor: int = 4) -> Observations:
    """``observations`` with ``factor - 1`` abscissae inserted evenly between consecutive records of every curve (the
    recorded ones kept, in their order); the values are placeholders (1.0), only the abscissae are meant."""
    steps = np.arange(factor) / factor
    tests = []
    for t in observations:
        curves = {}
        for name, c in t.curves.items():
            x = np.concatenate([(c.x[:-1, None] + steps[None, :] * np.diff(c.x)[:, None]).ravel(), c.x[-1:]])
            curves[name] = Curve(x, np.ones_like(x), c.x_name, c.y_name, c.x_unit, c.y_unit)
        tests.append(Test(t.name, curves, dict(t.conditions), t.source))
    return Observations(tests)


def with_mean_stress(observations) -> Observations:
    """``observations`` with a curve ``mean_stress`` (``mean_stress@<stage>``) beside every ``q`` (``q@<stage>``)
    curve, on its abscissae: what asks a forward model for p' along the triaxial stages (the stress paths); the
    values are the q curve's, placeholders."""
    tests = []
    for t in observations:
        curves = dict(t.curves)
        for key, c in t.curves.items():
            quantity, stage = split_key(key)
            if quantity == "q":
                name = "mean_stress" if stage is None else f"mean_stress@{stage}"
                curves.setdefault(name, Curve(c.x, c.y, c.x_name, "mean_stress", c.x_unit, "kPa"))
        tests.append(Test(t.name, curves, dict(t.conditions), t.source))
    return Observations(tests)


def dense_curves(simulate, observations, factor: int = 4) -> dict:
    """{(test, curve key): (x, y)} of ``simulate(densified observations)`` (a forward result {test: {key: values at
    the given abscissae, or (x, y)}}, or an Exception): every key whose values match a curve's dense abscissae
    (a test's other quantities, p' and q/p', on the abscissae its curves share). {} when the model fails there."""
    dense = densified(observations, factor)
    try:
        result = simulate(dense)
    except Exception:  # noqa: BLE001 - no dense curves: the figures draw the MAP at the records instead
        return {}
    if isinstance(result, Exception):
        return {}
    out = {}
    for t in dense:
        shared = next(iter(t.curves.values())).x
        for key, values in result.get(t.name, {}).items():
            if isinstance(values, tuple):
                out[t.name, key] = (np.asarray(values[0], float), np.asarray(values[1], float))
                continue
            x = t.curves[key].x if key in t.curves else shared
            if np.shape(values) == x.shape:
                out[t.name, key] = (x, np.asarray(values, float))
    return out
