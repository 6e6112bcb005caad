"""The registry of calibratable material models: what a study file or a calibration needs to know about each model,
collected from the class attributes of the model classes (:class:`constitutive.base.MaterialModel`).

    from constitutive.registry import MODELS, build_model
    spec = MODELS["SIMSAND"]                       # ModelSpec: parameters, ranges, switches, required, ...
    model = build_model("SIMSAND", values, {"lode_dependence": False})

Model names are the class names (``ModifiedCamClay``, ``ANICREEP``, ``SIMSAND``). Values are scalars or (n,) arrays
(one per point or particle) in the units of each parameter's :class:`~constitutive.base.ParameterRange`.

Enrichment families (:func:`enrichment_family`): the model whose switches add the missing physics of
``constitutive.physics_catalog`` to a base model. Modified Cam Clay belongs to the ANICREEP family: ANICREEP with
``anisotropy=False, viscous=False, destructuration=False, specific_volume="current"`` has MCC's elasticity, yield
surface, associated flow and hardening with MCC's current specific volume 1 + e (docs/reference.md section 4), and
:func:`mcc_as_anicreep` translates the parameters once.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass
from typing import Callable, NamedTuple

import numpy as np

from .anicreep import ANICREEP, anisotropy_constants
from .base import MaterialModel, ParameterError
from .invariants import deviatoric_stress, mean_stress
from .mcc import ModifiedCamClay
from .sand.simsand import SIMSAND
from .swelling import SWELLING_RANGES, SWELLING_SWITCH, DelayedSwelling

__all__ = ["ModelSpec", "MODELS", "SBP_MODELS", "model_spec", "build_model", "class_name", "Family",
           "enrichment_family", "mcc_as_anicreep", "k0_surface_ratio", "CONVENTIONS", "conventions"]


@dataclass(frozen=True)
class ModelSpec:
    """One calibratable model: its class and the metadata of its class attributes.

    cls           the model class;
    parameters    the parameter names (``parameter_names``);
    required      parameters needed whatever the switches (``required_parameters``);
    switches      physics switch -> default (``switches``);
    defaults      optional parameter -> the constructor's default (``parameter_defaults``);
    exactly_one   groups of which exactly one parameter is given; ``at_most_one``: at most one;
    catalog       the missing-physics catalog's switches this model does not take, with its value
                  (``catalog_switches``);
    needs         switch -> the parameters it needs when on, not parameters when off (``switch_parameters``);
    e0_parameter  the void ratio is a model parameter, else a condition of each test (``void_ratio_parameter``);
    max_strain_step  the laboratory drivers' default largest strain step, None: the model's own triaxial
                  integrator controls its substeps;
    ranges        parameter -> ParameterRange (physical range, checked on construction; typical range of soils);
    constraints   expressions between parameters the model enforces (``parameter_constraints``, e.g.
                  "kappa < lambda_"), a study's prior is restricted by them.
    """

    cls: type
    parameters: tuple
    required: tuple
    switches: dict
    defaults: dict
    exactly_one: tuple
    at_most_one: tuple
    catalog: dict
    needs: dict
    e0_parameter: bool
    max_strain_step: float | None
    ranges: dict
    constraints: tuple = ()

    @classmethod
    def of(cls, model_class: type[MaterialModel]) -> ModelSpec:
        """The spec of a model class, read from its class attributes."""
        return cls(model_class, tuple(model_class.parameter_names), tuple(model_class.required_parameters),
                   dict(model_class.switches), dict(model_class.parameter_defaults), tuple(model_class.exactly_one),
                   tuple(model_class.at_most_one), dict(model_class.catalog_switches),
                   dict(model_class.switch_parameters), bool(model_class.void_ratio_parameter),
                   model_class.max_strain_step, dict(model_class.parameter_ranges),
                   tuple(model_class.parameter_constraints))

    def needed(self, switches: dict) -> tuple:
        """The parameters the model needs with ``switches`` (unnamed switches at their defaults): the required ones
        and those of every switch that is on; the exactly-one groups are not included."""
        on = {**self.switches, **{k: v for k, v in switches.items() if k in self.switches}}
        return self.required + tuple(p for s, names in self.needs.items() if on[s] for p in names)

    def typical_values(self, switches: dict) -> dict:
        """Every needed parameter (:meth:`needed`) and the first of each exactly-one group at the middle of its
        typical range: a valid parameter set of a usual soil (examples, tests, starting values)."""
        names = self.needed(switches) + tuple(group[0] for group in self.exactly_one)
        return {k: self.ranges[k].middle for k in names}


#: the models a study can calibrate, by class name
MODELS = {c.__name__: ModelSpec.of(c) for c in (ModifiedCamClay, ANICREEP, SIMSAND)}
#: the models the pressuremeter FE runs: those whose update returns the consistent tangent (the FE Newton converges
#: quadratically with it; SIMSAND's continuum tangent would make it linear)
SBP_MODELS = tuple(sorted(k for k, spec in MODELS.items() if spec.cls.tangent_kind == "consistent"))


def model_spec(model: str) -> ModelSpec:
    """The ModelSpec of ``model`` (a key of MODELS); ParameterError naming it and the known models otherwise."""
    try:
        return MODELS[model]
    except (KeyError, TypeError):
        raise ParameterError(f"unknown model {model!r}: known models are {', '.join(MODELS)}") from None


def build_model(model: str, values: dict, switches: dict, vertical_axis=1) -> MaterialModel:
    """The material-point model ``model`` with parameter ``values`` (scalars or (n,) arrays) and ``switches``.

    ``switches`` may also hold constructor arguments that an enrichment of the missing-physics catalog fixes (a
    parameter such as ANICREEP's xi_d): where a name is in both, ``values`` wins. The switch ``swelling`` (any
    model) puts delayed swelling in series with it (``constitutive.swelling.DelayedSwelling``, parameters kappa_s
    and tau_s in ``values``). ``vertical_axis`` (1, 2, 3: the
    Voigt component of the deposition axis; 2 in the axisymmetric FE) goes to the models that take it (``oriented``).
    Raises ParameterError naming the model and the parameter for an unknown model, an unknown name, a missing
    required parameter or a value outside its physical range.
    """
    spec = model_spec(model)
    if switches.get(SWELLING_SWITCH):  # delayed swelling in series with the model (constitutive.swelling)
        own = {k: values[k] for k in SWELLING_RANGES if k in values}
        missing = [k for k in SWELLING_RANGES if k not in own]
        if missing:
            raise ParameterError(f"{model}: missing required parameter{'s' if len(missing) > 1 else ''} "
                                 f"{', '.join(missing)} for {SWELLING_SWITCH}=True")
        base = build_model(model, {k: v for k, v in values.items() if k not in own},
                           {k: v for k, v in switches.items() if k != SWELLING_SWITCH}, vertical_axis)
        return DelayedSwelling(base, own["kappa_s"], own["tau_s"])
    arguments = {**switches, **values}
    accepted = set(inspect.signature(spec.cls).parameters) - {"vertical_axis"}
    unknown = sorted(k for k in arguments if k not in accepted)
    if unknown:
        raise ParameterError(f"{model}: unknown parameter or switch {', '.join(unknown)} (parameters: "
                             f"{', '.join(spec.parameters)}; switches: {', '.join(spec.switches) or 'none'})")
    missing = [k for k in spec.needed(switches) if k not in arguments and k not in spec.defaults]
    if missing:
        on = {k: switches.get(k, v) for k, v in spec.switches.items()}
        raise ParameterError(f"{model}: missing required parameter{'s' if len(missing) > 1 else ''} "
                             f"{', '.join(missing)} for {class_name(on, model)}")
    if spec.cls.oriented:
        arguments["vertical_axis"] = vertical_axis
    return spec.cls(**arguments)


def class_name(switches: dict, model: str = "ANICREEP") -> str:
    """The name of a model class with its switches, e.g. ``ANICREEP(anisotropy=True, viscous=False)`` (switches
    sorted by name; the name identifies a calibrated class in outputs and reports)."""
    return f"{model}(" + ", ".join(f"{k}={v}" for k, v in sorted(switches.items())) + ")"


# ---------------------------------------------------------------------------------------------- enrichment families
class Family(NamedTuple):
    """The model class that carries a base model's enrichments.

    model      the family's model name (a key of MODELS);
    switches   the family's switches that reproduce the base model (all physics of the catalog off), with the
               constructor options that do too (ANICREEP's ``specific_volume``);
    translate  ``translate(values, stress0, void_ratio0) -> family values``: the base model's parameter values
               (scalars or (n,) arrays) at a specimen's initial effective stress ``stress0`` ((6,) or (n, 6), kPa,
               Voigt, axis 1 vertical) and void ratio ``void_ratio0``, as the family's constructor values; names
               the base model does not know (an enrichment's extra parameters) pass through unchanged.
    """

    model: str
    switches: dict
    translate: Callable


def _same(values, stress0=None, void_ratio0=None) -> dict:
    """The identity translation of a model that is its own family."""
    return dict(values)


def k0_surface_ratio(M):
    """p'_m / sigma'_p of ANICREEP's isotropic surface (alpha = 0) through the K0_nc state at sigma'_v = sigma'_p
    (``ANICREEP.reference_size``): with K0_nc = 1 - sin phi', sin phi' = 3M/(6 + M) (docs/reference.md section 4,
    (K)), p' = (1 + 2K0_nc) sigma'_p/3, q = (1 - K0_nc) sigma'_p and the ellipse p'_m = p' + q^2/(M^2 p') (Eq. (F)):
        p'_m/sigma'_p = (1 + 2K0_nc)/3 + 3 (1 - K0_nc)^2 / (M^2 (1 + 2K0_nc))."""
    k0 = anisotropy_constants(M)[0]
    M = np.asarray(M, dtype=float)
    return (1.0 + 2.0 * k0) / 3.0 + 3.0 * (1.0 - k0) ** 2 / (M**2 * (1.0 + 2.0 * k0))


def mcc_as_anicreep(values: dict, stress0, void_ratio0) -> dict:
    """ANICREEP values that reproduce Modified Cam Clay ``values`` (M, lambda_, kappa, G or nu, pc0 or ocr) for a
    specimen starting at effective stress ``stress0`` with void ratio ``void_ratio0``, with every ANICREEP switch off.

    - M, lambda_, kappa: the same (the same ellipse q^2 = M^2 p'(p'_c - p'), associated flow, NCL and swelling slopes
      in e-ln p');
    - e0 = void_ratio0 (ANICREEP's void ratio is its parameter; MCC takes it from the test);
    - sigma_p0 = p'_c0 / k0_surface_ratio(M): ANICREEP places its reference surface through the K0_nc state at
      sigma'_v = sigma'_p0, so this sigma'_p0 (the vertical preconsolidation stress on the K0_nc path of MCC's own
      ellipse) gives p'_m^r0 = p'_c0, MCC's initial surface; p'_c0 = pc0, or ocr (default 1) times the size of the
      surface through ``stress0``, p' + q^2/(M^2 p') (``ModifiedCamClay.initial_state``). With ANICREEP's anisotropy
      switched on, the rotated surface passes through the same vertical preconsolidation point;
    - nu: the same; a constant shear modulus G becomes the Poisson's ratio giving G at the initial state,
      nu = (3K - 2G)/(2(3K + G)), K = (1 + e0) p'_0/kappa (MCC's G stays constant, ANICREEP's grows with p': the
      one parameter mapped only approximately).
    Other names (an enrichment's extra parameters: C_alpha_e, tau, chi0, xi, xi_d) pass through.

    The family's ``specific_volume="current"`` makes ANICREEP integrate with MCC's current specific volume 1 + e_n
    (frozen over an increment, as MCC does), so the strain at which a state is reached is the same in both, also in
    stages after a consolidation (tests/constitutive/test_model_family.py, test_family_staged.py). ``void_ratio0``
    is the specimen's initial void ratio.
    """
    v = dict(values)
    M = np.asarray(v["M"], dtype=float)
    stress0 = np.atleast_2d(np.asarray(stress0, dtype=float))
    p0, q0 = mean_stress(stress0), deviatoric_stress(stress0)
    pc0, ocr = v.pop("pc0", None), v.pop("ocr", None)
    if pc0 is None:
        pc0 = (1.0 if ocr is None else np.asarray(ocr, dtype=float)) * (p0 + q0**2 / (M**2 * p0))
    G = v.pop("G", None)
    e0 = np.asarray(void_ratio0, dtype=float)
    if G is not None:
        K = (1.0 + e0) * p0 / np.asarray(v["kappa"], dtype=float)
        v["nu"] = (3.0 * K - 2.0 * np.asarray(G, dtype=float)) / (2.0 * (3.0 * K + np.asarray(G, dtype=float)))
    v["e0"] = e0
    v["sigma_p0"] = np.asarray(pc0, dtype=float) / k0_surface_ratio(M)
    return {k: (x.item() if isinstance(x, np.ndarray) and x.size == 1 else x) for k, x in v.items()}


#: base model -> its enrichment family (a model not listed is its own family)
FAMILIES = {"ModifiedCamClay": Family("ANICREEP", {"anisotropy": False, "viscous": False, "destructuration": False,
                                                   "specific_volume": "current"}, mcc_as_anicreep)}


def enrichment_family(model: str) -> Family:
    """The enrichment family of the base ``model`` (a key of MODELS): ``Family(model, switches, translate)``;
    a model with switches of its own is its own family (switches {}, identity translation)."""
    model_spec(model)
    return FAMILIES.get(model, Family(model, {}, _same))


# ---------------------------------------------------------------------------------------------- conventions
#: constructor options that write the same model another way: the curves change, the physics does not (both are
#: called Modified Cam Clay in the literature; docs/reference.md section 9). option -> {value: the convention in
#: words}
CONVENTIONS = {"specific_volume": {"current": "specific volume 1 + e (current)",
                                   "initial": "specific volume 1 + e0 (held at its initial value)"}}


def conventions(model: str, switches: dict) -> list:
    """The conventions of the base ``model`` with ``switches``: [(option, value, in words)], the one it is written in
    first, then every other value of each :data:`CONVENTIONS` option that its class, or its enrichment family's
    (``enrichment_family``: Modified Cam Clay through ANICREEP), takes as a constructor option."""
    family = enrichment_family(model)
    cls = model_spec(family.model).cls
    out = []
    for option, values in CONVENTIONS.items():
        if option not in cls.option_names:
            continue
        own = switches.get(option, family.switches.get(option,
                                                       inspect.signature(cls.__init__).parameters[option].default))
        out += [(option, own, values[own])] + [(option, v, words) for v, words in values.items() if v != own]
    return out
