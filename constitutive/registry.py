"""The registry of calibratable material models: what a study file or a calibration needs to know about each model,
collected from the class attributes of the model classes (:class:`constitutive.base.MaterialModel`).

    from constitutive.registry import MODELS, build_model
    spec = MODELS["SIMSAND"]                       # ModelSpec: parameters, ranges, switches, required, ...
    model = build_model("SIMSAND", values, {"lode_dependence": False})

Model names are the class names (``ModifiedCamClay``, ``ANICREEP``, ``SIMSAND``). Values are scalars or (n,) arrays
(one per point or particle) in the units of each parameter's :class:`~constitutive.base.ParameterRange`.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass

from .anicreep import ANICREEP
from .base import MaterialModel, ParameterError
from .mcc import ModifiedCamClay
from .simsand import SIMSAND

__all__ = ["ModelSpec", "MODELS", "SBP_MODELS", "model_spec", "build_model", "class_name"]


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
    parameter such as ANICREEP's xi_d): where a name is in both, ``values`` wins. ``vertical_axis`` (1, 2, 3: the
    Voigt component of the deposition axis; 2 in the axisymmetric FE) goes to the models that take it (``oriented``).
    Raises ParameterError naming the model and the parameter for an unknown model, an unknown name, a missing
    required parameter or a value outside its physical range.
    """
    spec = model_spec(model)
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
