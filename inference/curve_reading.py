"""Simulated curves read at the recorded abscissae, for every parameter set of a batch at once: the interpolation of
the likelihood (Eq. (5) compares the simulated and the recorded values at the recorded abscissae). The values are
those of ``np.interp`` (its arithmetic, node by node), computed once per grid: the plan of which nodes bracket each
recorded abscissa is kept for the last simulation grid of each curve (a batch forward model uses one grid
throughout). Units are those of the curves.
"""
from __future__ import annotations

import numpy as np

from .forward import ForwardModelError
from .observations import Observations

__all__ = ["CurveReader"]


class CurveReader:
    """Reads simulated curves of ``observations`` at their recorded abscissae (:meth:`at_records`)."""

    def __init__(self, observations: Observations):
        self.observations = observations
        # the recorded span of each curve with the tolerance of its coverage by a simulation
        self._span = {(t.name, cname): (c.x.min(), c.x.max(), 1e-9 * max(1.0, np.max(np.abs(c.x))))
                      for t in observations for cname, c in t.curves.items()}
        self._plans = {}  # (test, curve) -> (simulation abscissa bytes, interpolation plan), the last one seen

    def _plan(self, test, cname, xs):
        """How to read a curve simulated at abscissae ``xs`` at the recorded ones with np.interp's arithmetic:
        (order of xs, node index j per recorded x, recorded points strictly between two nodes, their x - xs[j],
        xs[j+1] - xs[j]). Cached for the last xs of each curve (a batch forward model uses one grid throughout).
        ForwardModelError if xs is too short, not finite, or does not cover the record."""
        key = xs.tobytes()
        cached = self._plans.get((test, cname))
        if cached is not None and cached[0] == key:
            return cached[1]
        if xs.size < 2 or not np.isfinite(xs).all():
            raise ForwardModelError(f"test {test}, curve {cname}: simulated curve has NaN/inf")
        c = self.observations[test].curves[cname]
        lo, hi, tol = self._span[test, cname]
        order = np.argsort(xs, kind="stable")
        xs = xs[order]
        if xs[0] > lo + tol or xs[-1] < hi - tol:
            raise ForwardModelError(f"test {test}, curve {cname}: simulation covers {c.x_name} in [{xs[0]:g}, "
                                    f"{xs[-1]:g}] but the record spans [{lo:g}, {hi:g}]")
        # np.interp: the end value at and beyond either end, the node value on a node, else
        # y[j] + slope * (x - xs[j]) with slope = (y[j+1] - y[j]) / (xs[j+1] - xs[j]) and xs[j] <= x < xs[j+1]
        j = np.clip(np.searchsorted(xs, c.x, side="right") - 1, 0, xs.size - 1)
        between = np.flatnonzero((c.x > xs[0]) & (c.x < xs[-1]) & (c.x != xs[j]))
        jb = j[between]
        plan = (None if np.array_equal(order, np.arange(xs.size)) else order, j, between, jb,
                c.x[between] - xs[jb], xs[jb + 1] - xs[jb])
        self._plans[test, cname] = (key, plan)
        return plan

    def at_records(self, test, cname, sim, m):
        """One simulated curve of m parameter sets -> (values (m, n_recorded) at the recorded abscissae, rows whose
        simulated values are not finite (m,), the reason for those rows). ``sim``: (x_sim, y) with y (n,) or (m, n),
        or y at the recorded abscissae ((n_recorded,) or (m, n_recorded)). ForwardModelError for what makes the curve
        unusable for every row (missing, wrong size, abscissa not covering the record)."""
        if sim is None:
            raise ForwardModelError(f"forward model returned no curve {cname!r} for test {test!r}")
        n_rec = self.observations[test].curves[cname].y.size
        if isinstance(sim, tuple):
            xs, ys = (np.asarray(v, dtype=float) for v in sim)
            if ys.size != m * xs.size:
                raise ForwardModelError(f"test {test}, curve {cname}: {ys.size} simulated values for {xs.size} "
                                        f"abscissae" + (f" x {m} parameter sets" if m > 1 else ""))
            ys = ys.reshape(m, xs.size)
            order, j, between, jb, dx, width = self._plan(test, cname, xs.ravel())
            if order is not None:
                ys = ys[:, order]
            values = ys[:, j]
            if between.size:
                y0 = ys[:, jb]
                values[:, between] = (ys[:, jb + 1] - y0) / width * dx + y0
            # finite nodes interpolate to finite values (an overflow aside, which Eq. (5) turns into -inf anyway)
            return values, ~np.isfinite(ys).all(axis=1), f"test {test}, curve {cname}: simulated curve has NaN/inf"
        values = np.asarray(sim, dtype=float)
        if values.size != m * n_rec:
            raise ForwardModelError(f"test {test}, curve {cname}: {values.size} simulated values for "
                                    + (f"{m} x " if m > 1 else "") + f"{n_rec} recorded points")
        values = values.reshape(m, n_rec)
        return values, ~np.isfinite(values).all(axis=1), f"test {test}, curve {cname}: simulated values contain NaN/inf"
