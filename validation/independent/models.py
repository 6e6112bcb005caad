"""Constitutive models of the independent generator, written in triaxial invariants (axisymmetric states only).

Sign and unit convention: compression positive, stresses in kPa (effective), strains as fractions.
p = (sigma_a + 2 sigma_r)/3, q = sigma_a - sigma_r (signed: q < 0 in extension), eps_v = eps_a + 2 eps_r,
eps_q = 2/3 (eps_a - eps_r); v = 1 + e, updated by dv = -v d(eps_v).

Elasticity (Roscoe & Burland 1968; Wood 1990, Eq. 3.13-3.14): swelling lines e = e_kappa - kappa ln p', i.e. the
bulk modulus K = v p' / kappa, shear modulus G = 3 K (1 - 2 nu) / (2 (1 + nu)) (constant Poisson's ratio):
    dp = K d(eps_v^e),  dq = 3 G d(eps_q^e).                                                        (1)

Conventions (all called Modified Cam Clay in the literature; options of both models, defaults first):
- ``specific_volume``: "current" uses v = 1 + e in Eq. (1) and (3); "initial" holds it at the specimen's v0 = 1 + e0
  (``ClayState.v0``), so that ln p' is linear in the volumetric strain;
- ``compression``: "e-lnp" (e linear in ln p', slopes lambda, kappa); "lnv-lnp" (Butterfield 1979: ln v linear in
  ln p', slopes lambda* = ``lambda_``, kappa* = ``kappa``): the factor v of Eq. (1) and (3) becomes 1;
- ``elasticity``: "nu" (constant Poisson's ratio, Eq. 1) or "G" (constant shear modulus ``G``, kPa; K still from the
  swelling line).

:class:`ElastoplasticClay` -- Modified Cam Clay (Roscoe & Burland 1968) with two optional additions, each a switch:
- anisotropy: the ellipse inclined in p'-q by a fixed alpha (S-CLAY1 in triaxial form, Wheeler et al. 2003, Eq. 1;
  no rotational hardening):
      f = (q - alpha p)^2 - (M^2 - alpha^2) (p_m - p) p = 0;  alpha = 0 is MCC;                     (2)
- destructuration (S-CLAY1S, Koskinen et al. 2002; Gens & Nova 1993): apparent size p_m = (1 + chi) p_mi of the
  intrinsic size p_mi, with
      d p_mi = v p_mi d(eps_v^p) / (lambda - kappa),                                                  (3)
      d chi = -a chi (|d eps_v^p| + b |d eps_q^p|).                                                   (4)
Associated flow d(eps^p) = dL (df/dp, df/dq); the plastic multiplier from consistency df = 0:
      dL = n . De d(eps) / (n . De n + H),  H = -df/dp_m (d p_m / dL).                                 (5)
Without destructuration p_m = p_mi hardens by Eq. (3): e-ln p' normal compression line of slope lambda.

:class:`ViscousClay` -- Modified Cam Clay ellipse with a creep-rate law instead of a yield condition (Vermeer &
Neher 1999 soft-soil-creep in triaxial form; Bjerrum 1967 time lines): no elastic domain, the viscoplastic strain
rate is
      d(eps^vp)/dt = psi / (v tau) (p_eq / p_p)^beta  (n_p, n_q),  beta = (lambda - kappa) / psi,       (6)
      p_eq = p + q^2 / (M^2 p),  n = ((2 p - p_eq) / p_eq, 2 q / (M^2 p_eq))  (normal to the ellipse, n_p = 1 on
      the isotropic axis),  psi = C_alpha_e / ln 10,
      d p_p = v p_p d(eps_v^vp) / (lambda - kappa).                                                    (7)
Under a held isotropic stress the void ratio follows e(t) = e_0 - psi ln(1 + R0^beta t / tau), R0 = p_eq/p_p at the
start of the hold (Eq. 8): the secondary compression slope de/d(log10 t) tends to C_alpha_e; a tenfold strain rate
raises the undrained strength by about 10^(1/beta).
Three optional additions to the creep-rate law, each a parameter (all zero: Eq. 6-7 exactly), for clays showing
two effects at once:
- an inclined ellipse (``alpha``; the time lines of an anisotropic creep model, Leoni, Karstunen & Vermeer 2008,
  ACM in triaxial form without rotational hardening): p_eq of Eq. (2) through (p, q) and its normal
      p_eq = p + (q - alpha p)^2 / ((M^2 - alpha^2) p),
      n = ((2 p - p_eq) / p_eq - 2 alpha (q - alpha p) / ((M^2 - alpha^2) p_eq),
           2 (q - alpha p) / ((M^2 - alpha^2) p_eq));                                                  (9)
- bonding (``chi0``, ``a``, ``b``; as in Creep-SCLAY1S, Sivasithamparam, Karstunen & Bonnier 2015, triaxial form):
  the apparent reference size (1 + chi) p_p replaces p_p in Eq. (6), p_p hardening by Eq. (7) and chi degrading
  with the viscoplastic strain by Eq. (4);
- delayed swelling (``kappa_s`` (-), ``tau_s`` (s)): a volumetric Kelvin element in series, our own simple form of
  the time-dependent swelling after unloading that Yin & Graham (1999) model by an elastic visco-plastic law, its
  strain eps_s (compression positive, so <= 0 after unloading)
      d eps_s / dt = (eps_s_eq - eps_s) / tau_s,  eps_s_eq = kappa_s / v min(0, ln(p / p_max)),         (10)
  v the volume factor of the conventions, p_max the largest p reached in the test (the specimen's own history: at
  the start p_max = p, eps_s = 0, its sampling swelling taken as complete). Under a held p after unloading
  eps_s(t) = eps_s_eq + (eps_s(0) - eps_s_eq) exp(-t / tau_s) (v constant): with the strain held the effective
  stress rises, under a held stress the specimen keeps swelling. The viscoplastic strain alone hardens p_p.

Both models expose ``moduli(state)`` (Eq. 1) and ``advance``; the elastoplastic one ``plastic(state)`` for Eq. (5),
the viscous one ``creep_rate(state)`` (Eq. 6, 9) and ``swelling_rate(state)`` (Eq. 10); the mixed-control integrator
(:mod:`validation.independent.integrator`) does the rest.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["ClayState", "ElastoplasticClay", "ViscousClay", "ellipse_size"]


@dataclass
class ClayState:
    """Mutable material state: effective p, q (kPa), specific volume v, size of the surface (p_mi: intrinsic size
    for the elastoplastic model, p_p: the intrinsic preconsolidation of the creep law, kPa), bonding chi (-), the
    initial specific volume v0 (the "initial" specific-volume convention), the delayed swelling strain eps_s (-,
    compression positive) and the largest p reached p_max (kPa; None: p) of the creep law's Eq. (10)."""

    p: float
    q: float
    v: float
    size: float
    chi: float = 0.0
    v0: float | None = None
    swell: float = 0.0
    p_max: float | None = None


def ellipse_size(p: float, q: float, M: float, alpha: float = 0.0) -> float:
    """p_m of the (inclined) ellipse Eq. (2) through (p, q) (kPa)."""
    return p + (q - alpha * p) ** 2 / ((M * M - alpha * alpha) * p)


class _Elastic:
    """Eq. (1) and the conventions of the module docstring: the elastic moduli and the volume factor."""

    def __init__(self, kappa, nu, specific_volume="current", compression="e-lnp", elasticity="nu", G=None):
        if specific_volume not in ("current", "initial") or compression not in ("e-lnp", "lnv-lnp"):
            raise ValueError(f"unknown convention {specific_volume!r}, {compression!r}")
        if (elasticity == "G") != (G is not None) or elasticity not in ("nu", "G"):
            raise ValueError("elasticity 'G' takes a shear modulus G (kPa); 'nu' none")
        self.kappa, self.nu, self.G = kappa, nu, G
        self.specific_volume, self.compression = specific_volume, compression

    def volume(self, s: ClayState):
        """The factor v of Eq. (1) and (3): v, v0 or 1 (module docstring)."""
        if self.compression == "lnv-lnp":
            return 1.0
        return s.v if self.specific_volume == "current" else s.v0

    def moduli(self, s: ClayState):
        K = self.volume(s) * s.p / self.kappa
        if self.G is not None:
            return K, self.G + 0.0 * K
        return K, 3.0 * K * (1.0 - 2.0 * self.nu) / (2.0 * (1.0 + self.nu))


class ElastoplasticClay(_Elastic):
    """Rate-independent MCC, optionally inclined (``alpha``) and bonded (``chi0``, ``a``, ``b``); Eq. (1)-(5)."""

    viscous = False

    def __init__(self, M, lambda_, kappa, nu, alpha=0.0, a=0.0, b=0.0, **conventions):
        super().__init__(kappa, nu, **conventions)
        self.M, self.lambda_, self.alpha, self.a, self.b = M, lambda_, alpha, a, b

    def initial_state(self, p, q, v, sigma_p_point, chi0=0.0) -> ClayState:
        """State at (p, q, v) whose apparent surface passes through the stress point ``sigma_p_point`` = (p, q) of
        the preconsolidation; the bonding chi0 splits it into intrinsic and bonded parts."""
        pm = ellipse_size(*sigma_p_point, self.M, self.alpha)
        return ClayState(p, q, v, pm / (1.0 + chi0), chi0, v)

    def yield_value(self, s: ClayState) -> float:
        """f of Eq. (2), scaled by 1/p_m^2 (dimensionless; < 0 inside)."""
        pm = (1.0 + s.chi) * s.size
        return ((s.q - self.alpha * s.p) ** 2 - (self.M ** 2 - self.alpha ** 2) * (pm - s.p) * s.p) / pm ** 2

    def plastic(self, s: ClayState):
        """(n_p, n_q, H) of Eq. (5): the gradient of f and the hardening modulus."""
        al, m2 = self.alpha, self.M ** 2 - self.alpha ** 2
        pm = (1.0 + s.chi) * s.size
        n_p = -2.0 * al * (s.q - al * s.p) - m2 * (pm - 2.0 * s.p)
        n_q = 2.0 * (s.q - al * s.p)
        dpm = ((1.0 + s.chi) * self.volume(s) * s.size * n_p / (self.lambda_ - self.kappa)
               - s.size * self.a * s.chi * (abs(n_p) + self.b * abs(n_q)))
        return n_p, n_q, m2 * s.p * dpm

    def advance(self, s: ClayState, dev, deq, dev_p, deq_p):
        """Update the state for total strain increments (dev, deq) of which (dev_p, deq_p) are plastic: Eq. (1),
        (3), (4)."""
        K, G = self.moduli(s)
        s.p += K * (dev - dev_p)
        s.q += 3.0 * G * (deq - deq_p)
        s.size += self.volume(s) * s.size * dev_p / (self.lambda_ - self.kappa)
        s.chi -= self.a * s.chi * (abs(dev_p) + self.b * abs(deq_p))
        s.v -= s.v * dev


class ViscousClay(_Elastic):
    """MCC ellipse with the creep-rate law Eq. (6)-(7) (``C_alpha_e``, reference time ``tau`` in s), optionally
    inclined (``alpha``, Eq. 9), bonded (``chi0`` in :meth:`initial_state`, ``a``, ``b``) and with delayed swelling
    (``kappa_s``, ``tau_s`` in s, Eq. 10)."""

    viscous = True

    def __init__(self, M, lambda_, kappa, nu, C_alpha_e, tau=86400.0, alpha=0.0, a=0.0, b=0.0, kappa_s=0.0,
                 tau_s=86400.0, **conventions):
        super().__init__(kappa, nu, **conventions)
        self.M, self.lambda_, self.tau, self.alpha, self.a, self.b = M, lambda_, tau, alpha, a, b
        self.kappa_s, self.tau_s = kappa_s, tau_s
        self.psi = C_alpha_e / math.log(10.0)
        self.beta = (lambda_ - kappa) / self.psi

    def initial_state(self, p, q, v, sigma_p_point, chi0=0.0) -> ClayState:
        """State at (p, q, v) whose apparent reference surface (the tau time line) passes through
        ``sigma_p_point``; the bonding chi0 splits it into intrinsic and bonded parts."""
        pm = ellipse_size(*sigma_p_point, self.M, self.alpha)
        return ClayState(p, q, v, pm / (1.0 + chi0), chi0, v, 0.0, p)

    def creep_rate(self, s: ClayState):
        """(d eps_v^vp/dt, d eps_q^vp/dt) of Eq. (6) and (9), 1/s."""
        al = self.alpha
        m2 = self.M * self.M - al * al
        peq = ellipse_size(s.p, s.q, self.M, al)
        ratio = peq / ((1.0 + s.chi) * s.size)
        rate = self.psi / (s.v * self.tau) * math.exp(self.beta * math.log(ratio)) if ratio > 0 else 0.0
        return (rate * ((2.0 * s.p - peq) / peq - 2.0 * al * (s.q - al * s.p) / (m2 * peq)),
                rate * 2.0 * (s.q - al * s.p) / (m2 * peq))

    def swelling_rate(self, s: ClayState) -> float:
        """d eps_s/dt of Eq. (10), 1/s (<= 0 while swelling)."""
        if self.kappa_s == 0.0:
            return 0.0
        p_max = s.p if s.p_max is None else max(s.p_max, s.p)
        target = self.kappa_s / self.volume(s) * min(0.0, math.log(s.p / p_max))
        return (target - s.swell) / self.tau_s

    def advance(self, s: ClayState, dev, deq, dev_p, deq_p, dev_s=0.0):
        """Update the state for total strain increments (dev, deq) of which (dev_p, deq_p) are viscoplastic and
        dev_s delayed swelling: Eq. (1), (4), (7), (10)."""
        K, G = self.moduli(s)
        s.p += K * (dev - dev_p - dev_s)
        s.q += 3.0 * G * (deq - deq_p)
        s.size += self.volume(s) * s.size * dev_p / (self.lambda_ - self.kappa)
        s.chi -= self.a * s.chi * (abs(dev_p) + self.b * abs(deq_p))
        s.swell += dev_s
        s.p_max = s.p if s.p_max is None else max(s.p_max, s.p)
        s.v -= s.v * dev
