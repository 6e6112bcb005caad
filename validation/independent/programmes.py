"""The laboratory programmes of the independent generator, the clay and its hidden effects.

One clay (Modified Cam Clay base: M = 1.2, lambda = 0.25, kappa = 0.05, nu = 0.25; in situ vertical
preconsolidation 100 kPa on the K0 = 0.55 line) with one hidden effect per data set (:data:`EFFECTS`):
``none`` (plain MCC, the negative control), ``viscosity`` (creep-rate law, C_alpha_e = 0.015, tau = 1 day),
``anisotropy`` (ellipse inclined at alpha = 0.30), ``destructuration`` (bonding chi0 = 1.5, a = 8, b = 0.4); see
:mod:`validation.independent.models` for the equations. Two effects at once (:data:`COMBINED`, the programmes of
:mod:`validation.independent.multi`): the creep-rate law with delayed swelling (kappa_s = 0.02, tau_s = 1 day), with
the inclined ellipse (alpha = 0.30) or with bonding (chi0 = 1.5, a = 8, b = 0.4).
The K0 of normally consolidated states (:func:`k0_nc`) is the given 0.55 (the in situ preconsolidation line; the
specimens' stated initial K0); the model-form controls (:mod:`validation.independent.controls`) take Jaky's or the
flow rule's instead, and the models' other conventions through :func:`material`.

Programmes (:data:`PROGRAMMES`), each a list of :class:`Test` (initial state + stages, units kPa, s, 1/s, strains
as fractions here and % in the files, compression positive):
- ``ciu``: isotropic consolidation to 200 kPa (1 day), a 1-day hold, swelling to OCR 1, 2, 4 (1 day), undrained
  compression at 0.5 %/h to 15 %;
- ``ck0u``: K0 consolidation (sigma'_h = 0.55 sigma'_v) to sigma'_v 200 kPa (1 day), 1-day hold, undrained
  compression and extension at 0.5 %/h to 12 %;
- ``crs``: oedometer CRS at 1e-6 and 1e-5 1/s to 20 % then unloading at the opposite rate to sigma'_v 50 kPa;
- ``il``: incremental oedometer 25, 50, 100, 200, 400, 800 kPa held 1 h, 1 day, 1 day, 7 days, 1 day, 1 day, then
  unloading to 200 kPa held 1 day (10 s ramps): a load-increment ratio of 1 to 8 times the preconsolidation, so
  that the virgin compression curve is defined over more than one increment, as laboratories load;
- ``relaxation``: multistage oedometer relaxation: CRS (1e-6 1/s) with a 1-day relaxation at 5, 10, 15 and 20 %
  axial strain, then unloading to sigma'_v 60 kPa and a 1-day relaxation (relaxation at one strain level of 12 %
  left a bonded clay's records within the noise of the plain clay's, E/2 = 1.9 in
  :mod:`validation.independent.identifiability`; the four levels give 55).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .integrator import Control, Point, run_stage
from .models import ClayState, ElastoplasticClay, ViscousClay

__all__ = ["CLAY", "EFFECTS", "COMBINED", "Stage", "Test", "PROGRAMMES", "material", "k0_nc", "simulate"]

#: base parameters of the clay (kPa), the in situ preconsolidation (vertical, kPa) and its K0 line
CLAY = {"M": 1.2, "lambda_": 0.25, "kappa": 0.05, "nu": 0.25, "sigma_p": 100.0, "K0_nc": 0.55}
#: hidden effect -> its generating parameters
EFFECTS = {"none": {}, "viscosity": {"C_alpha_e": 0.015, "tau": 86400.0}, "anisotropy": {"alpha": 0.30},
           "destructuration": {"chi0": 1.5, "a": 8.0, "b": 0.4}}
#: delayed swelling after unloading (models Eq. 10): slope in e-ln p' (-) and time constant (s)
SWELLING = {"kappa_s": 0.02, "tau_s": 86400.0}
#: two hidden effects at once, named "<effect>+<effect>" -> the generating parameters of both
COMBINED = {"viscosity+time-dependent swelling": {**EFFECTS["viscosity"], **SWELLING},
            "viscosity+anisotropy": {**EFFECTS["viscosity"], **EFFECTS["anisotropy"]},
            "viscosity+destructuration": {**EFFECTS["viscosity"], **EFFECTS["destructuration"]}}
DAY = 86400.0


def material(effect: str, clay: dict | None = None, conventions: dict | None = None):
    """(model, chi0) of the clay with ``effect`` (of :data:`EFFECTS` or :data:`COMBINED`: the creep-rate law where
    it holds viscosity, else the elastoplastic clay, with the effect's other parameters); ``clay`` overrides values
    of :data:`CLAY` and of the effect's own parameters (e.g. ``C_alpha_e``), ``conventions`` are the models'
    convention options (:mod:`validation.independent.models`; default ours)."""
    c, e, conv = {**CLAY, **(clay or {})}, {**EFFECTS, **COMBINED}[effect], conventions or {}
    e = {k: c.get(k, v) for k, v in e.items()}
    base = (c["M"], c["lambda_"], c["kappa"], c["nu"])
    options = {k: v for k, v in e.items() if k not in ("C_alpha_e", "tau", "chi0")}
    if "C_alpha_e" in e:
        return ViscousClay(*base, e["C_alpha_e"], e["tau"], **options, **conv), e.get("chi0", 0.0)
    return ElastoplasticClay(*base, **options, **conv), e.get("chi0", 0.0)


def k0_nc(convention: str, clay: dict | None = None) -> float:
    """K0 of normally consolidated states (-): "given" (``K0_nc`` of :data:`CLAY`), "jaky" (1 - sin phi', sin phi' =
    3 M / (6 + M), triaxial compression), or "mcc" (the flow rule's one-dimensional K0 of the elastoplastic clay:
    eta (kappa 2 (1 + nu) / (9 (1 - 2 nu))) + (lambda - kappa) 2 eta / (M^2 - eta^2) = 2 lambda / 3 solved by
    bisection, K0 = (3 - eta) / (3 + 2 eta))."""
    c = {**CLAY, **(clay or {})}
    if convention == "given":
        return c["K0_nc"]
    M, lam, kap, nu = c["M"], c["lambda_"], c["kappa"], c["nu"]
    if convention == "jaky":
        return 1.0 - 3.0 * M / (6.0 + M)
    if convention != "mcc":
        raise ValueError(f"unknown K0 convention {convention!r}")
    g = kap * 2.0 * (1.0 + nu) / (9.0 * (1.0 - 2.0 * nu))
    lo, hi = 1e-9, M - 1e-9
    for _ in range(80):
        eta = 0.5 * (lo + hi)
        if eta * g + (lam - kap) * 2.0 * eta / (M * M - eta * eta) > 2.0 * lam / 3.0:
            hi = eta
        else:
            lo = eta
    return (3.0 - eta) / (3.0 + 2.0 * eta)


@dataclass(frozen=True)
class Stage:
    """One stage: ``kind`` and ``name`` as in the study file, ``fields`` its study-file fields (strains in %),
    ``log`` how the laboratory logged it ("time" linear, "log" log-spaced hold, "strain" every few 0.1 %)."""

    kind: str
    name: str
    fields: dict
    log: str


@dataclass(frozen=True)
class Test:
    """A specimen: ``apparatus`` ("triaxial" | "oedometer"), its initial state (``p0`` or ``sigma_v0`` with
    ``K0``; ``e0``) and stages."""

    name: str
    apparatus: str
    initial: dict
    stages: tuple = field(default_factory=tuple)


def _ciu(ocr, e0):
    stages = [Stage("consolidation", "consolidation1", {"p": 200.0, "duration": DAY}, "time"),
              Stage("creep", "creep2", {"duration": DAY}, "log")]
    if ocr > 1:
        stages.append(Stage("consolidation", "swelling3", {"p": 200.0 / ocr, "duration": DAY}, "time"))
    stages.append(Stage("shear", f"shear{len(stages) + 1}", {"drainage": "undrained", "direction": "compression",
                                                             "strain_rate": 1.4e-6, "to_axial_strain": 15.0},
                        "strain"))
    return Test(f"CIU_OCR{ocr}", "triaxial", {"p0": 40.0, "e0": e0}, tuple(stages))


def _ck0u(direction, e0):
    return Test(f"CK0U{direction[0].upper()}", "triaxial", {"sigma_v0": 40.0, "K0": 0.55, "e0": e0},
                (Stage("consolidation", "consolidation1", {"sigma_v": 200.0, "K0": 0.55, "duration": DAY}, "time"),
                 Stage("creep", "creep2", {"duration": DAY}, "log"),
                 Stage("shear", "shear3", {"drainage": "undrained", "direction": direction, "strain_rate": 1.4e-6,
                                           "to_axial_strain": 12.0}, "strain")))


def _crs(rate, e0):
    return Test("CRS_fast" if rate > 2e-6 else "CRS_slow", "oedometer", {"sigma_v0": 20.0, "K0": 0.55, "e0": e0},
                (Stage("crs", "loading1", {"strain_rate": rate, "to_axial_strain": 20.0}, "strain"),
                 Stage("crs", "unloading2", {"strain_rate": -rate, "to_sigma_v": 50.0}, "strain")))


def _il(e0):
    hours = (("25", 3600.0), ("50", DAY), ("100", DAY), ("200", 7 * DAY), ("400", DAY), ("800", DAY), ("200", DAY))
    return Test("IL", "oedometer", {"sigma_v0": 10.0, "K0": 0.55, "e0": e0},
                tuple(Stage("load", f"load{k}", {"sigma_v": float(s), "ramp_time": 10.0, "duration": d}, "log")
                      for k, (s, d) in enumerate(hours, start=1)))


def _relaxation(e0, levels=(5.0, 10.0, 15.0, 20.0)):
    stages = []
    for strain in levels:
        stages += [Stage("crs", f"loading{len(stages) + 1}", {"strain_rate": 1e-6, "to_axial_strain": strain},
                         "strain"),
                   Stage("relaxation", f"relaxation{len(stages) + 2}", {"duration": DAY}, "log")]
    stages += [Stage("crs", f"unloading{len(stages) + 1}", {"strain_rate": -1e-6, "to_sigma_v": 60.0}, "strain"),
               Stage("relaxation", f"relaxation{len(stages) + 2}", {"duration": DAY}, "log")]
    return Test("OED_relax", "oedometer", {"sigma_v0": 20.0, "K0": 0.55, "e0": e0}, tuple(stages))


#: programme -> (one-line description for the file headers, its tests)
PROGRAMMES = {
    "ciu": ("isotropically consolidated undrained compression (CIU) at OCR 1, 2, 4",
            (_ciu(1, 1.28), _ciu(2, 1.25), _ciu(4, 1.30))),
    "ck0u": ("K0-consolidated undrained compression and extension (CK0UC, CK0UE)",
             (_ck0u("compression", 1.27), _ck0u("extension", 1.29))),
    "crs": ("constant-rate-of-strain oedometer at two rates a decade apart, loading then unloading",
            (_crs(1e-6, 1.26), _crs(1e-5, 1.28))),
    "il": ("incremental oedometer to 800 kPa and unloading, stages of 1 h to 7 days", (_il(1.27),)),
    "relaxation": ("multistage oedometer relaxation: four strain levels in loading, one after unloading",
                   (_relaxation(1.26),)),
}


def _control(point, test, stage):
    """The stage's Control(s) from the point's current stresses and strains."""
    f, oed = stage.fields, test.apparatus == "oedometer"
    radial_held = ("strain", 0.0) if oed else ("stress", 0.0)
    if stage.kind == "consolidation":
        d = f["duration"]
        if "p" in f:
            return [Control(("stress", (f["p"] - point.sigma_a) / d), ("stress", (f["p"] - point.sigma_r) / d), d)]
        return [Control(("stress", (f["sigma_v"] - point.sigma_a) / d),
                        ("stress", (f["K0"] * f["sigma_v"] - point.sigma_r) / d), d)]
    if stage.kind == "creep":
        return [Control(("stress", 0.0), radial_held, f["duration"])]
    if stage.kind == "relaxation":
        return [Control(("strain", 0.0), radial_held, f["duration"])]
    if stage.kind == "shear":
        rate = f["strain_rate"] * (1.0 if f["direction"] == "compression" else -1.0)
        radial = ("strain", -rate / 2.0) if f["drainage"] == "undrained" else ("stress", 0.0)
        return [Control(("strain", rate), radial, f["to_axial_strain"] / 100.0 / abs(rate))]
    if stage.kind == "crs":
        rate = f["strain_rate"]
        if "to_axial_strain" in f:
            return [Control(("strain", rate), ("strain", 0.0), (f["to_axial_strain"] / 100 - point.eps_a) / rate)]
        return [Control(("strain", rate), ("strain", 0.0), 1e9, until_sigma_a=f["to_sigma_v"])]
    if stage.kind == "load":
        ramp = f["ramp_time"]
        return [Control(("stress", (f["sigma_v"] - point.sigma_a) / ramp), ("strain", 0.0), ramp),
                Control(("stress", 0.0), ("strain", 0.0), f["duration"] - ramp)]
    raise ValueError(f"stage kind {stage.kind!r} of {test.name} is not generated")


def simulate(test: Test, effect: str, clay: dict | None = None, conventions: dict | None = None, k0: str = "given",
             **steps):
    """{stage name: (start index, end index)} and the trajectory rows (time s, eps_a, eps_r, sigma'_a, sigma'_r,
    e) of ``test`` on the clay with ``effect`` (``clay`` overrides values of :data:`CLAY`, ``conventions`` the
    models' options); ``k0`` the K0 convention (:func:`k0_nc`) of the in situ preconsolidation line and, other than
    "given", of the specimen's initial state too (its stated K0 replaced); ``steps`` go to :func:`run_stage`
    (sub-step sizes)."""
    model, chi0 = material(effect, clay, conventions)
    init = test.initial
    if "p0" in init:
        sa = sr = init["p0"]
    else:
        sa = init["sigma_v0"]
        sr = (init["K0"] if k0 == "given" else k0_nc(k0, clay)) * sa
    k0, c = k0_nc(k0, clay), {**CLAY, **(clay or {})}
    point_p = (c["sigma_p"] * (1 + 2 * k0) / 3.0, c["sigma_p"] * (1 - k0))
    state: ClayState = model.initial_state((sa + 2 * sr) / 3.0, sa - sr, 1.0 + init["e0"], point_p, chi0)
    point = Point(model, state)
    spans = {}
    for stage in test.stages:
        start = len(point.rows) - 1
        for ctrl in _control(point, test, stage):
            run_stage(point, ctrl, **steps)
        spans[stage.name] = (start, len(point.rows))
    return spans, point.rows
