"""Catalog of candidate missing physics for the missing-physics diagnosis (its "explain" step), kept beside the models.

Each entry states the physics in words, its residual signature as plain data that the generic scoring in
``inference.diagnose`` can use without knowing any soil mechanics, and the enrichment (model class, switches and
extra parameters with prior bounds) that adds the physics to a base model, or ``None`` with the reason when that
enriched class is not implemented.

Signature items (dicts, see :data:`SIGNATURE_KEYS`):
- ``covariate``: a name from :data:`COVARIATES` (the vocabulary forward models use when they report per-point
  covariates alongside their curves);
- ``role``: "primary" (the physics is named only if a primary item is supported) or "supporting";
- ``weight``: its weight in the signature score (primary 1, supporting 0.5);
- ``direction``: expected sign of the rank correlation between the covariate and the relative residual
  r = U_obs/U_sim - 1 on the curves named in ``curves`` (+1, -1, or 0 when only the strength of the link matters;
  categorical covariates always 0);
- ``curves``: the curve names on which the direction is measured (None: every curve);
- ``meaning``: the expected pattern in words.

Residual sign convention: r > 0 where the recorded value exceeds the simulated one (compression positive, so for the
stress curves of :data:`STRESS_CURVES` r > 0 means the soil was recorded stronger or stiffer than simulated).

Effective and total stresses: a rate trend of an effective stress (:data:`EFFECTIVE_STRESS_CURVES`) separates
viscosity (faster tests stronger) from partial drainage (slower tests drain more and are stronger); a total stress
such as the pressuremeter's cavity pressure carries the pore pressure too, and in the two-rate SBP both effects make
the faster test's total pressure higher than a rate-independent simulation (validation.proofs.sbp, data sets 1 and 2),
so on a total stress the rate trend only supports. With the pore pressure recorded (:data:`PORE_PRESSURE_CURVES`)
the two are told apart by its rate trend: a viscous soil generates less excess pore pressure in faster undrained
shear (the isotach effect, Sheahan, Ladd & Germaine 1996), whereas drainage that the assumed permeability
underestimates lowers the slower test's pore pressure more.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .registry import enrichment_family

__all__ = ["COVARIATES", "COUPLED_FE_ARGUMENTS", "STRESS_CURVES", "EFFECTIVE_STRESS_CURVES", "PORE_PRESSURE_CURVES",
           "STRAIN_CURVES", "SIGNATURE_KEYS", "Enrichment", "Candidate", "CATALOG", "candidate", "signatures",
           "enriched_settings"]

#: the switch and the parameter that go to a forward model solving consolidation (the SBP's coupled FE) instead of
#: the material: the partial drainage enrichment's ``forward_arguments``
COUPLED_FE_ARGUMENTS = ("coupled", "permeability")

#: covariate vocabulary: name -> what a forward model reports under that name
COVARIATES = {
    "strain rate": "applied strain rate of the test or stage (1/s, magnitude); constant along a curve",
    "time": "time since the start of the stage (s; of the test for a one-stage test)",
    "hold time after loading": "time since the start of a hold (creep, relaxation, a load stage's hold, an SBP hold; "
                               "s) that follows loading; undefined elsewhere",
    "hold time after unloading": "time since the start of a hold that follows unloading (swelling) (s); undefined "
                                 "elsewhere",
    "consolidation compression": "the recorded compression index of a consolidation stage, -de/dln p' (or "
                                 "sigma'_v) between neighbouring records, over the MAP's (-); undefined outside "
                                 "consolidation and crs stages",
    "strain level": "axial (or cavity) strain at the point",
    "post-peak strain": "strain beyond the peak of the recorded deviator stress of the test (defined on the softening "
                        "branch only: undefined before the peak and in records that peak at their last point)",
    "stress ratio": "q/p' at the point (simulated at the MAP)",
    "mean effective stress": "p' at the point (kPa, simulated at the MAP)",
    "overconsolidation": "overconsolidation ratio at the point",
    "initial state parameter": "sand state parameter at the start of the test, psi_0 = e_0 - e_c(p'_0) (Been & "
                               "Jefferies 1985; negative: denser than critical; e_c of the MAP); a test condition",
    "drainage time factor": "T = c t / L^2 (consolidation coefficient c, drainage length L)",
    "loading phase": "'loading', 'unloading' or 'hold' of the stage at the point (categorical)",
    "stress path direction": "'compression' or 'extension' (categorical test condition)",
    "consolidation": "'K0' or 'isotropic' consolidation before shearing (categorical test condition)",
}

#: curves whose values are effective or total stresses, compression positive
STRESS_CURVES = ("q", "p", "axial_stress", "radial_stress", "cavity_pressure")
#: the effective-stress curves among them (laboratory drivers: q, p', sigma'_a, sigma'_r); cavity_pressure is total
EFFECTIVE_STRESS_CURVES = ("q", "p", "axial_stress", "radial_stress")
#: recorded pore pressures (total, or in excess of the initial value)
PORE_PRESSURE_CURVES = ("pore_pressure", "excess_pore_pressure")
#: recorded compressive strains (%, compression positive): they grow in creep under constant stress
STRAIN_CURVES = ("axial_strain", "volumetric_strain")

SIGNATURE_KEYS = ("covariate", "role", "weight", "direction", "curves", "meaning")


def _item(covariate, role, direction, meaning, curves=STRESS_CURVES):
    return {"covariate": covariate, "role": role, "weight": 1.0 if role == "primary" else 0.5,
            "direction": direction, "curves": None if curves is None else list(curves), "meaning": meaning}


@dataclass(frozen=True)
class Enrichment:
    """How to add the physics: construct ``model_class`` with the base model's arguments plus ``switches`` (the
    physics switch and any constructor argument the enrichment holds fixed), and free ``parameters``
    {name: (lower, upper)} (log-uniform prior for the names in ``log_uniform``). ``forward_arguments``: the names
    among switches and parameters that go to the forward model instead of ``model_class`` (e.g. the permeability
    of the coupled FE). ``inert_at``: {parameter: "lower" or "upper"}, the end of an added parameter's prior where
    the enriched class is the base class again or is no longer the physics the candidate names (a viscosity
    coefficient at its floor; a swelling time constant at its floor is an instantaneous compliance, not a time
    effect): an enriched class whose mode sits there cannot confirm the candidate. ``seen_in_shear``: the added
    parameters the records show only where a specimen is sheared away from its consolidation path (a triaxial shear
    stage, the pressuremeter's cavity expansion); a one-dimensional programme (oedometer, CRS, incremental loading,
    relaxation) leaves them out of the prior, at the model's own values (:func:`enriched_settings`)."""

    model_class: str
    switches: dict
    parameters: dict
    log_uniform: tuple = ()
    forward_arguments: tuple = ()
    inert_at: dict = field(default_factory=dict)
    seen_in_shear: tuple = ()

    def __post_init__(self):
        for name, end in self.inert_at.items():
            if name not in self.parameters or end not in ("lower", "upper"):
                raise ValueError(f"enrichment {self.switches}: inert_at {name}={end!r} must name a free parameter "
                                 "and 'lower' or 'upper'")
        if not set(self.seen_in_shear) <= set(self.parameters):
            raise ValueError(f"enrichment {self.switches}: seen_in_shear {self.seen_in_shear} must name free "
                             "parameters")


@dataclass(frozen=True)
class Candidate:
    """One candidate missing physics.

    present_when: model switches under which the base model already has the physics (then it is not a candidate
    for that base); enrichment: None when not implemented, with ``unavailable`` saying why."""

    name: str
    physics: str
    signature: tuple
    present_when: dict
    enrichment: Enrichment | None
    unavailable: str = ""
    references: tuple = field(default_factory=tuple)

    def as_data(self) -> dict:
        """The entry as plain data for ``inference.diagnose`` (no classes, JSON-serializable)."""
        e = self.enrichment
        return {"name": self.name, "physics": self.physics, "signature": [dict(s) for s in self.signature],
                "present_when": dict(self.present_when),
                "enrichment": None if e is None else {"model_class": e.model_class, "switches": dict(e.switches),
                                                      "parameters": {k: list(v) for k, v in e.parameters.items()},
                                                      "log_uniform": list(e.log_uniform),
                                                      "forward_arguments": list(e.forward_arguments),
                                                      "inert_at": dict(e.inert_at)},
                "unavailable": self.unavailable}


CATALOG = (
    Candidate(
        "viscosity",
        "Rate dependence, creep and relaxation of the soil skeleton (viscoplasticity): the faster a test is run the "
        "stronger and stiffer the soil; under constant stress it keeps straining (secondary compression).",
        (_item("strain rate", "primary", +1, "recorded effective stresses exceed the simulation more in faster "
               "tests", EFFECTIVE_STRESS_CURVES),
         _item("strain rate", "primary", -1, "faster tests generate less excess pore pressure than simulated (the "
               "soil is stiffer and less contractive at a higher rate)", PORE_PRESSURE_CURVES),
         _item("strain rate", "supporting", +1, "recorded total pressures exceed the simulation more in faster tests "
               "(partial drainage does the same: not diagnostic alone)", ("cavity_pressure",)),
         _item("hold time after loading", "primary", -1, "relaxation after loading: with the strain held the "
               "recorded effective stresses fall below the rate-independent simulation the longer the hold (a total "
               "pressure also falls as the pore pressure dissipates: not diagnostic)", EFFECTIVE_STRESS_CURVES),
         _item("hold time after loading", "primary", +1, "creep after loading: under held stress the recorded "
               "compression grows beyond the simulation the longer the hold", STRAIN_CURVES),
         _item("hold time after loading", "supporting", -1, "creep after loading: the void ratio keeps falling "
               "below the simulation (secondary compression)", ("void_ratio",)),
         _item("time", "supporting", -1, "the longer a record has run, the more the soil has crept: recorded "
               "stresses fall below the simulation late and in slow tests"),
         _item("loading phase", "supporting", 0, "holds (creep, relaxation) misfit differently from loading; after "
               "unloading a viscous soil relaxes little (its stress lies inside the yield surface), so holds after "
               "unloading carry little of this signature", None)),
        {"viscous": True},
        Enrichment("ANICREEP", {"viscous": True}, {"C_alpha_e": (0.001, 0.1)}, ("C_alpha_e",),
                   inert_at={"C_alpha_e": "lower"}),
        references=("docs/reference.md section 4: beta = (lambda - kappa)/C_alpha_e, CRS ratio "
                    "(rate2/rate1)^(C_alpha_e/lambda)",)),
    Candidate(
        "time-dependent swelling",
        "Swelling that continues with time after unloading (creep after unloading, the time-dependent rebound of "
        "natural clays, often attributed to the delayed expansion of the clay fabric): under constant stress after "
        "an unloading the specimen keeps expanding; with the strain held the effective stress rises. An "
        "overstress viscoplastic model gives nothing of the kind (after unloading its stress lies inside the yield "
        "surface and it creeps, slowly, in compression).",
        (_item("hold time after unloading", "primary", -1, "creep after unloading: the recorded compressive strain "
               "falls below the simulation the longer the hold (continued swelling)", STRAIN_CURVES),
         _item("hold time after unloading", "primary", +1, "relaxation after unloading: with the strain held the "
               "recorded effective stresses rise above the simulation the longer the hold", EFFECTIVE_STRESS_CURVES),
         _item("hold time after unloading", "supporting", +1, "the void ratio keeps rising above the simulation "
               "after unloading", ("void_ratio",)),
         _item("loading phase", "supporting", 0, "holds after unloading misfit unlike holds after loading", None)),
        {"swelling": True},
        # delayed swelling in series with the base (constitutive.swelling, (S1)-(S4)): kappa_s, the delayed
        # swelling's slope in e-ln p', log-uniform over 0.001-0.05 (a fraction to about half of the kappa of soft
        # clays); tau_s, its time constant, log-uniform over 100 s to 4 months (laboratory holds last hours to weeks)
        Enrichment("ANICREEP", {"swelling": True}, {"kappa_s": (0.001, 0.05), "tau_s": (1.0e2, 1.0e7)},
                   ("kappa_s", "tau_s"), inert_at={"kappa_s": "lower", "tau_s": "lower"}),
        references=("Yin & Graham (1999) elastic visco-plastic swelling; Leroueil, Kabbaj, Tavenas & Bouchard (1985) "
                    "stress-strain-strain rate relation; constitutive/swelling.py (S1)-(S4)",)),
    Candidate(
        "partial drainage",
        "Pore water flows during the test: neither the drained nor the undrained idealization holds. The excess pore "
        "pressure generated by loading dissipates while the test runs, the more the longer the drainage time (the "
        "slower the test, the more permeable the soil, the shorter the drainage path); the effective stress path "
        "changes with it (in contractive soil the slower test drains more and is stronger).",
        (_item("drainage time factor", "primary", -1, "recorded pore pressure falls below the simulation more where "
               "more drainage time has passed (T = c t / L^2: lower excess pore pressure than the assumed "
               "drainage allows)", ("pore_pressure", "excess_pore_pressure")),
         _item("strain rate", "supporting", -1, "slower tests (more drainage) are stronger than simulated in "
               "effective stress: the opposite rate trend to viscosity", EFFECTIVE_STRESS_CURVES),
         _item("strain rate", "primary", +1, "the slower test's pore pressure falls further below the simulation "
               "than the faster one's (more drainage than the assumed permeability allows: the between-test face of "
               "the drainage time factor)", PORE_PRESSURE_CURVES)),
        {"coupled": True},
        # SBP scale only: the coupled FE (fem.pressuremeter, validation.proofs.sbp) re-solved with the permeability of
        # each particle (fem.Solver.solve(permeability=...)); "coupled" is a forward-model switch, not an ANICREEP
        # argument. k log-uniform over five decades (clays 1e-11 to silts 1e-6 m/s).
        Enrichment("ANICREEP", {"coupled": True}, {"permeability": (1e-11, 1e-6)}, ("permeability",),
                   forward_arguments=COUPLED_FE_ARGUMENTS, inert_at={"permeability": "lower"}),
        "the lab-test drivers (constitutive.labtests) treat a specimen as one material point, drained or undrained; "
        "the enrichment (permeability free, m/s) exists only for forward models that solve consolidation (the SBP "
        "FE in fem/, switch 'coupled')"),
    Candidate(
        "anisotropy",
        "Initial (K0) and induced fabric anisotropy: a rotated yield surface with rotational hardening; compression "
        "and extension, K0 and isotropic consolidation respond differently from an isotropic model.",
        (_item("stress path direction", "primary", 0, "compression and extension tests misfit with opposite "
               "signs", None),
         _item("consolidation", "supporting", 0, "K0- and isotropically consolidated tests misfit differently (only "
               "where the consolidation induces a different fabric: isotropic reconsolidation below the "
               "preconsolidation stress keeps the natural K0 fabric)", None),
         _item("stress ratio", "supporting", 0, "misfit grows with the stress ratio as the stress path turns "
               "towards the rotated surface")),
        {"anisotropy": True},
        # S-CLAY1's initial fabric alpha_K0 and rotation rate omega follow from M (docs/reference.md section 4, (K));
        # a natural clay's fabric and how fast it rotates are its own: the initial inclination alpha0 (alpha_K0 is
        # 0.32-0.64 for M 0.8-1.6; 0 is isotropic) and the factor omega_ratio on omega (0: a fixed fabric, the
        # inclined ellipse of Wheeler et al. 2003 Eq. 1; 1: S-CLAY1) are free, uniform. With alpha_K0 and omega from
        # M, the anisotropic class fitted an independent CK0U programme of a clay with a fixed fabric (inclination
        # 0.30) with 28 % RMS misfit of q in extension at the generating M, lambda and kappa (the preconsolidation
        # scanned); with alpha0 = 0.30 and omega_ratio = 0, 2 %. Only shearing shows them: along a one-dimensional
        # path the fabric follows the K0 line whatever its start and rate (the generator's anisotropic clay leaves
        # CRS, IL and relaxation records consistent with noise), and free there they bend the compression curve
        # like bonding (IL: ln B 60.4 and 62.0 against destructuration's 57.6 and 72.4, the true effect).
        Enrichment("ANICREEP", {"anisotropy": True}, {"alpha0": (0.0, 0.75), "omega_ratio": (0.0, 2.0)},
                   seen_in_shear=("alpha0", "omega_ratio")),
        references=("docs/reference.md section 4: alpha_K0, omega, omega_d from M; constitutive/anicreep.py (I): "
                    "the initial fabric alpha0 and omega_ratio",)),
    Candidate(
        "destructuration",
        "Bonding and structure of natural (sensitive) clay destroyed by plastic straining: the soil yields at an "
        "apparent preconsolidation stress above its intrinsic one, then softens towards the reconstituted response "
        "(a peak and post-peak strength loss in undrained shear, in compression and extension alike; a steep "
        "post-yield compression curve). The strength loss follows accumulated plastic strain, not the strain rate "
        "or the stress path direction.",
        (_item("post-peak strain", "primary", -1, "on the softening branch the recorded stresses fall further below "
               "the simulation the more the soil is strained past its peak"),
         _item("strain level", "supporting", 0, "the misfit changes with strain level in every test alike (above "
               "the simulation around the peak, below it at large strain)"),
         _item("overconsolidation", "supporting", 0, "tests starting further inside the apparent yield surface "
               "destructure later and misfit differently"),
         _item("consolidation compression", "supporting", 0, "past the apparent preconsolidation stress the recorded "
               "compression curve is steeper than the model's (structure collapsing), so the void-ratio misfit "
               "follows the ratio of the recorded to the simulated compression index", ("void_ratio",))),
        {"destructuration": True},
        # S-CLAY1S / EVP-SCLAY1S bonding (constitutive.anicreep, (D)). Priors (literature values recalled, not
        # re-checked against the papers here): chi0 ~ sensitivity - 1, reported 4-12 for Scandinavian and Scottish
        # soft clays (Murro, Bothkennar) and higher for very sensitive clays; log-uniform [0.1, 50] spans nearly
        # unstructured to highly sensitive (quick clays excluded). xi (S-CLAY1S "a") reported 8-12; log-uniform
        # [1, 30] spans a decade below and a factor 2.5 above. xi_d ("b") fixed at 0.2, the value most reported
        # (0.2-0.4): in undrained shear d eps_v^vp is small, so destructuration is driven by xi xi_d eps_d^vp and the
        # two are identifiable only as a product; fixing xi_d keeps two extra parameters on a ridge-free prior.
        Enrichment("ANICREEP", {"destructuration": True, "xi_d": 0.2}, {"chi0": (0.1, 50.0), "xi": (1.0, 30.0)},
                   ("chi0", "xi"), inert_at={"chi0": "lower", "xi": "lower"}),
        references=("Koskinen, Karstunen & Wheeler (2002) S-CLAY1S; Yin, Karstunen, Chang, Koskinen & Lojander "
                    "(2011) EVP-SCLAY1S; constitutive/anicreep.py (D)",)),
    Candidate(
        "state-dependent dilatancy",
        "Sand dilatancy and peak strength depending on the state (density and pressure, through the critical state "
        "line e_c(p')): denser-than-critical states interlock, peak above the critical-state ratio and dilate; looser "
        "ones contract and harden without a peak; both end at the critical state, where the effect vanishes.",
        (_item("initial state parameter", "primary", -1, "the denser than critical a test starts (the more negative "
               "psi_0), the more its recorded stresses and void ratio exceed the simulation (a peak and dilation the "
               "base model lacks), and the looser, the more they fall below it",
               EFFECTIVE_STRESS_CURVES + ("void_ratio",)),
         _item("mean effective stress", "supporting", 0, "the misfit changes with confining pressure at a given "
               "density (the same void ratio is further from e_c(p') at low p')"),
         _item("strain level", "supporting", 0, "the misfit peaks around the strength peak and fades at large strain "
               "(critical state)")),
        {"state_dependent_dilatancy": True},
        # SIMSAND's interlocking (VII) on: n_p, n_d free with the paper's SIMSAND priors (uniform [0.1, 10] both,
        # cases/studies/simsand_synthetic.toml; the printed table of the paper swaps them)
        Enrichment("SIMSAND", {"state_dependent_dilatancy": True}, {"n_p": (0.1, 10.0), "n_d": (0.1, 10.0)},
                   inert_at={"n_p": "lower", "n_d": "lower"}),
        references=("docs/reference.md section 3 (VII): tan phi_p = (e_c/e)^n_p tan phi_mu, tan phi_pt = (e_c/e)^-n_d "
                    "tan phi_mu; Been & Jefferies (1985) state parameter",)),
    Candidate(
        "Lode dependence",
        "Strength depending on the Lode angle: triaxial extension (and plane strain) fail at a lower stress ratio "
        "than compression (Sheng, Sloan & Yu 2000: M_e = c M_c, c = (3 - sin phi)/(3 + sin phi)); a model with a "
        "circular deviatoric section overpredicts the extension strength or, calibrated on both, misfits compression "
        "and extension with opposite signs.",
        (_item("stress path direction", "primary", 0, "extension and compression tests misfit differently "
               "(extension recorded weaker than simulated)", None),
         _item("stress ratio", "supporting", 0, "the misfit grows as the stress ratio approaches failure (the Lode "
               "rule changes the failure ratio, not the elastic start)")),
        {"lode_dependence": True},
        # no extra parameter: c follows from phi_p and phi_pt (docs/reference.md section 3)
        Enrichment("SIMSAND", {"lode_dependence": True}, {}),
        references=("docs/reference.md section 3: Sheng, Sloan & Yu (2000) M(theta) on M_p and M_pt",)),
)


def candidate(name: str) -> Candidate:
    """The catalog entry called ``name`` (ValueError naming the known ones otherwise)."""
    for c in CATALOG:
        if c.name == name:
            return c
    raise ValueError(f"candidate physics {name!r} is not in the catalog; known: {[c.name for c in CATALOG]}")


def _in_base(c: Candidate, base_switches: dict) -> bool:
    """True when a base model with ``base_switches`` already has the physics of candidate ``c``."""
    return bool(c.present_when) and all(base_switches.get(k) == v for k, v in c.present_when.items())


def _unavailable(c: Candidate, model_class) -> str:
    """Why candidate ``c`` cannot enrich a base model of class ``model_class`` (None: any class), or "". A base model
    is enriched through its family (``constitutive.registry.enrichment_family``: Modified Cam Clay through ANICREEP
    with every switch off)."""
    if c.enrichment is None:
        return c.unavailable
    family = None if model_class is None else enrichment_family(model_class).model
    if family is not None and c.enrichment.model_class != family:
        return (f"{model_class} has no switch for it (the enrichment is {c.enrichment.model_class} "
                f"{', '.join(f'{k}={v}' for k, v in c.enrichment.switches.items())})")
    return ""


def signatures(base_switches: dict, model_class: str | None = None) -> list:
    """The catalog as plain data for a base model with ``base_switches`` (e.g. {"viscous": False,
    "anisotropy": True}); each entry gains ``in_base`` (True when the base model already has the physics). With
    ``model_class`` (the base model's class), an enrichment outside the class's family is given as ``enrichment`` None
    with the reason in ``unavailable``; an enrichment through another class of the family (an MCC base enriched as
    ANICREEP) names the base class in ``enrichment["translated_from"]`` and the family's switches that reproduce it
    in ``enrichment["family_switches"]``."""
    out = []
    family = None if model_class is None else enrichment_family(model_class)
    for c in CATALOG:
        d = c.as_data()
        d["in_base"] = _in_base(c, base_switches)
        reason = _unavailable(c, model_class)
        if reason:
            d.update(enrichment=None, unavailable=reason)
        elif d["enrichment"] is not None and family is not None and family.model != model_class:
            d["enrichment"].update(translated_from=model_class, family_switches=dict(family.switches))
        out.append(d)
    return out


def enriched_settings(name: str, base_switches: dict, base_bounds: dict, model_class: str | None = None,
                      shears: bool = True) -> tuple:
    """(switches, prior bounds, log-uniform names) of the enriched class of candidate ``name`` for a base model with
    ``base_switches`` and free-parameter ``base_bounds`` (of class ``model_class`` when given), on a programme that
    ``shears`` a specimen (False: the enrichment's ``seen_in_shear`` parameters stay out of the prior). For a base
    model enriched through another class of its family (``constitutive.registry.enrichment_family``: Modified Cam
    Clay -> ANICREEP), the switches are the family's (every physics off) plus the enrichment's, and the bounds keep
    the base model's parameter names (the forward model translates them, ``Family.translate``) plus the
    enrichment's extra parameters. Raises ValueError when the enrichment is not implemented or is outside the
    class's family (message: the reason) or the base model already has the physics."""
    c = candidate(name)
    reason = _unavailable(c, model_class)
    if reason:
        raise ValueError(f"candidate {name!r}: enrichment not available: {reason}")
    if _in_base(c, base_switches):
        raise ValueError(f"candidate {name!r}: the base model already has it (switches {base_switches})")
    overlap = set(c.enrichment.parameters) & set(base_bounds)
    if overlap:
        raise ValueError(f"candidate {name!r}: parameters {sorted(overlap)} are already free in the base model")
    family = None if model_class is None else enrichment_family(model_class)
    switches = dict(family.switches) if family is not None and family.model != model_class else dict(base_switches)
    added = {k: v for k, v in c.enrichment.parameters.items() if shears or k not in c.enrichment.seen_in_shear}
    return ({**switches, **c.enrichment.switches}, {**base_bounds, **added},
            tuple(k for k in c.enrichment.log_uniform if k in added))
