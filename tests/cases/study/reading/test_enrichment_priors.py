"""The study file's [enrichment.<candidate>] priors (cases.study.reading.enrichment_priors): read with the catalog's
prior form unless a table gives another, under either spelling of a candidate; a candidate the base already has is
refused. The one-line refusals of bad tables (exit status 2) are in the corpus, tests/corpus_inputs.py."""
from __future__ import annotations

from pathlib import Path

import pytest
from corpus_inputs import LAB_CSV, LAB_TOML

from cases.study.checks import StudyError
from cases.study.reading.schema import load_study


def _study(tmp_path, text):
    (tmp_path / "t1.csv").write_text(LAB_CSV)
    path = tmp_path / "study.toml"
    path.write_text(text)
    return path


def test_enrichment_priors_are_read_with_the_catalog_prior_form_unless_given(tmp_path):
    study = load_study(_study(tmp_path, LAB_TOML + """
[enrichment.viscosity]
C_alpha_e = [0.0005, 0.05]
[enrichment.time_dependent_swelling]
tau_s = { bounds = [3600.0, 1.0e6], prior = "uniform" }
[enrichment.destructuration]
chi0 = [1.0, 20.0]
xi = { bounds = [2.0, 20.0], prior = "log-uniform" }
[enrichment.anisotropy]
omega_ratio = [0.0, 1.0]
"""))
    assert study.enrichment_priors == {
        "viscosity": {"C_alpha_e": (0.0005, 0.05, "log-uniform")},
        "time-dependent swelling": {"tau_s": (3600.0, 1.0e6, "uniform")},
        "destructuration": {"chi0": (1.0, 20.0, "log-uniform"), "xi": (2.0, 20.0, "log-uniform")},
        "anisotropy": {"omega_ratio": (0.0, 1.0, "uniform")}}
    assert load_study(_study(tmp_path, LAB_TOML)).enrichment_priors == {}


def test_a_candidate_the_base_already_has_is_refused(tmp_path):
    text = (LAB_TOML.replace('name = "ModifiedCamClay"', 'name = "ANICREEP"\nviscous = true')
            .replace("nu = 0.3", "nu = 0.3\ne0 = 1.0\nC_alpha_e = 0.01").replace("e0 = 1.0\nstrain_rate",
                                                                                 "strain_rate")
            .replace("ocr = {", "sigma_p0 = {").replace("bounds = [1.0, 4.0]", "bounds = [50.0, 400.0]")
            + "\n[enrichment.viscosity]\nC_alpha_e = [0.001, 0.05]\n")
    with pytest.raises(StudyError, match=r"enrichment.viscosity = \{'C_alpha_e': \[0.001, 0.05\]\}: the base model "
                                         r"already has 'viscosity' \(viscous = true\)"):
        load_study(_study(tmp_path, text))


def test_a_candidate_that_adds_no_parameter_is_refused(tmp_path):
    """SIMSAND's Lode dependence adds no parameter: a prior for it is refused, naming the table."""
    examples = Path(__file__).resolve().parents[4] / "cases" / "examples"
    text = (examples / "sand_lab.toml").read_text().replace('"data/', f'"{examples}/data/')
    path = tmp_path / "study.toml"
    path.write_text(text + "\n[enrichment.Lode_dependence]\nx = [1, 2]\n")
    with pytest.raises(StudyError, match=r"enrichment.Lode_dependence = \{'x': \[1, 2\]\}: the 'Lode dependence' "
                                         r"enrichment adds no parameter"):
        load_study(path)
