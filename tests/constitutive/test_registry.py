"""The model registry (constitutive.registry): every registered model builds from typical values with every
combination of its switches, its metadata agrees with its constructor, and bad names raise ParameterError naming
them."""
import inspect
import itertools

import numpy as np
import pytest

from constitutive import ANICREEP, SIMSAND, MaterialModel, ModifiedCamClay, ParameterError
from constitutive.registry import MODELS, SBP_MODELS, build_model, class_name, model_spec


def switch_settings(spec):
    """Every combination of the model's switches (the defaults first)."""
    names = list(spec.switches)
    for combo in itertools.product((True, False), repeat=len(names)):
        yield dict(zip(names, combo))


def test_registered_models_and_pressuremeter_models():
    assert list(MODELS) == ["ModifiedCamClay", "ANICREEP", "SIMSAND"]
    assert [MODELS[k].cls for k in MODELS] == [ModifiedCamClay, ANICREEP, SIMSAND]
    assert SBP_MODELS == ("ANICREEP", "ModifiedCamClay")


@pytest.mark.parametrize("name", list(MODELS))
def test_every_model_builds_from_mid_range_values_with_every_switch_setting(name):
    spec = MODELS[name]
    for switches in switch_settings(spec):
        values = spec.typical_values(switches)
        model = build_model(name, values, switches)
        assert isinstance(model, spec.cls)
        for k, v in values.items():
            assert np.all(getattr(model, k) == v), (k, switches)
        for k, on in switches.items():
            assert getattr(model, k) is on
        # the same values as (n,) arrays, one per particle
        batch = build_model(name, {k: np.full(3, v) for k, v in values.items()}, switches)
        assert all(np.shape(getattr(batch, k)) == (3,) for k in values)


@pytest.mark.parametrize("name", list(MODELS))
def test_metadata_agrees_with_the_constructor(name):
    spec = MODELS[name]
    signature = inspect.signature(spec.cls).parameters
    assert set(spec.switches) <= set(signature)
    for k, default in spec.switches.items():
        assert signature[k].default is default
    for k, default in spec.defaults.items():
        assert signature[k].default == default
    assert set(spec.parameters) <= set(spec.ranges)
    assert set(spec.required) <= set(spec.parameters)
    for names in spec.needs.values():
        assert set(names) <= set(spec.parameters) and not set(names) & set(spec.required)
    for k, r in spec.ranges.items():
        assert k in signature
        lo, hi = r.typical
        assert lo <= hi and r.check(k, [lo, r.middle, hi]).shape == (3,)  # the typical range is physical
    # a required parameter without a value is refused by the constructor itself
    for k in spec.required:
        values = spec.typical_values({})
        del values[k]
        with pytest.raises((ParameterError, TypeError)):
            spec.cls(**values)


@pytest.mark.parametrize("name", list(MODELS))
def test_values_outside_the_physical_range_raise_naming_the_parameter(name):
    spec = MODELS[name]
    values = spec.typical_values({})
    for k in values:
        r = spec.ranges[k]
        bad = r.lower - 1.0 if r.lower is not None else r.upper + 1.0
        with pytest.raises(ParameterError, match=rf"parameter {k} = "):
            build_model(name, {**values, k: bad}, {})


def test_unknown_model_raises_parameter_error_naming_it():
    with pytest.raises(ParameterError, match="'CamClay'.*ModifiedCamClay, ANICREEP, SIMSAND"):
        build_model("CamClay", {}, {})
    with pytest.raises(ParameterError, match="'CamClay'"):
        model_spec("CamClay")


@pytest.mark.parametrize("name", list(MODELS))
def test_unknown_parameter_or_switch_raises_parameter_error_naming_it(name):
    values = MODELS[name].typical_values({})
    with pytest.raises(ParameterError, match=f"{name}: unknown parameter or switch lamda"):
        build_model(name, {**values, "lamda": 0.2}, {})
    with pytest.raises(ParameterError, match=f"{name}: unknown parameter or switch creep"):
        build_model(name, values, {"creep": True})


@pytest.mark.parametrize("name", list(MODELS))
def test_missing_required_values_raise_parameter_error_naming_them(name):
    spec = MODELS[name]
    for switches in switch_settings(spec):
        values = spec.typical_values(switches)
        for k in spec.needed(switches):
            if k in spec.defaults:
                continue
            with pytest.raises(ParameterError, match=rf"{name}: missing required parameter {k} for "):
                build_model(name, {j: v for j, v in values.items() if j != k}, switches)


def test_switch_parameters_are_needed_only_when_the_switch_is_on():
    spec = MODELS["SIMSAND"]
    values = spec.typical_values({"state_dependent_dilatancy": False})
    assert "n_p" not in values and "n_d" not in values
    model = build_model("SIMSAND", values, {"state_dependent_dilatancy": False})
    assert model.n_p == 0.0 and model.n_d == 0.0
    with pytest.raises(ParameterError, match="missing required parameters n_p, n_d"):
        build_model("SIMSAND", values, {})
    anicreep = MODELS["ANICREEP"]
    assert anicreep.needed({"viscous": False}) == anicreep.required
    assert anicreep.needed({"destructuration": True})[-3:] == ("chi0", "xi", "xi_d")


def test_switches_may_fix_a_parameter_and_values_win():
    """An enrichment of the physics catalog may hold a parameter fixed among its switches (ANICREEP's xi_d)."""
    values = MODELS["ANICREEP"].typical_values({"destructuration": True})
    fixed = build_model("ANICREEP", {k: v for k, v in values.items() if k != "xi_d"},
                        {"destructuration": True, "xi_d": 0.0})
    assert fixed.xi_d == 0.0
    assert build_model("ANICREEP", values, {"destructuration": True, "xi_d": 0.0}).xi_d == values["xi_d"]


def test_vertical_axis_goes_to_oriented_models_only():
    values = MODELS["ANICREEP"].typical_values({})
    assert build_model("ANICREEP", values, {}).vertical_axis == 1
    assert build_model("ANICREEP", values, {}, vertical_axis=2).vertical_axis == 2
    assert isinstance(build_model("ModifiedCamClay", MODELS["ModifiedCamClay"].typical_values({}), {},
                                  vertical_axis=2), ModifiedCamClay)
    assert [k for k in MODELS if MODELS[k].cls.oriented] == ["ANICREEP"]
    assert MaterialModel.oriented is False


def test_class_name_lists_the_switches_sorted():
    assert class_name({"viscous": False, "anisotropy": True}) == "ANICREEP(anisotropy=True, viscous=False)"
    assert class_name({}, "SIMSAND") == "SIMSAND()"
