"""The Randolph & Wroth (1979) dissipation set-up shared by the FE holding-phase tests
(tests/fem/test_fem_dissipation.py) and the study library's SBP hold stage (tests/cases/test_sbp_stages.py): the soil,
the series at the wall and its T50.
"""
import numpy as np

import constitutive as C
from fem import oracles

A0 = 0.0415
G, SU, NU, K = 2000.0, 20.0, 0.3, 1e-9
R_OUT = 200.0                                   # outer radius / a0 (FE) = R*/a (series)
CH = oracles.consolidation_coefficient(K, G, NU)
RP = float(oracles.gibson_anderson(G, SU, 0.1)[1])       # plastic radius / a at 10 %: sqrt(G 2 eps/s_u) = 4.47
T_EXPAND = 0.01                                 # s


class ElasticDissipation(C.VonMises):
    """Von Mises during the fast expansion (dt < 1e-3 s), linear elastic (same G, nu) in the holding phase:
    Randolph & Wroth's assumption of elastic soil during dissipation."""

    rate_dependent = True          # the response depends on dt (the solver must call it at every iteration)

    def update(self, stress, state, dstrain, dt, tangent=True):
        if dt < 1e-3:
            return super().update(stress, state, dstrain, dt)
        s, st, D = C.LinearElastic(2 * G * (1 + NU), NU).update(stress, state, dstrain, dt)
        return s, dict(state, void_ratio=st["void_ratio"]), D


def t50(T, u):
    """Time factor at which the normalized wall pore pressure first falls to 0.5 (log-linear interpolation)."""
    j = int(np.flatnonzero(u < 0.5)[0])
    return float(np.exp(np.interp(0.5, [u[j], u[j - 1]], [np.log(T[j]), np.log(T[j - 1])])))


def series_wall(T):
    return oracles.randolph_wroth(1.0, T, RP, R_OUT, s_u=SU, n_terms=3000)[:, 0] / (2 * SU * np.log(RP))
