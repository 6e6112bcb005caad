"""The consolidation stage kind (cases.study.stages.consolidation): its target, defaults, checks and description."""
from __future__ import annotations

from stage_tables import WHERE, read, refused

from cases.study.stages.consolidation import CONSOLIDATION_DURATION, Consolidation


def test_isotropic_and_k0_targets():
    iso = read("triaxial", kind="consolidation", p=200.0)
    assert iso.procedure is Consolidation and iso.name == "consolidation2"
    assert (iso.p, iso.duration, iso.abscissa) == (200.0, CONSOLIDATION_DURATION, "p")
    k0 = read("triaxial", kind="consolidation", sigma_v=300.0, K0=0.5, duration=600.0)
    assert (k0.sigma_v, k0.K0, k0.duration, k0.abscissa) == (300.0, 0.5, 600.0, "sigma_v")
    assert iso.describe() == "consolidation2: to p' 200 kPa"
    assert k0.describe() == "consolidation2: to sigma'_v 300 kPa (K0 0.5)"
    oed = read("oedometer", kind="consolidation", sigma_v=100.0)
    assert oed.describe() == "consolidation2: to sigma'_v 100 kPa"


def test_refusals():
    refused("triaxial", f"{WHERE}: a consolidation stage goes to p (isotropic, triaxial) or to sigma_v (kPa), one of "
            "them; got ['p', 'sigma_v']", kind="consolidation", p=100.0, sigma_v=100.0)
    refused("triaxial", f"{WHERE}.K0 is missing (a triaxial consolidation to sigma_v holds sigma'_h = K0 sigma'_v)",
            kind="consolidation", sigma_v=100.0)
    refused("triaxial", f"{WHERE}.K0 = 0.5: an isotropic consolidation (p) has no K0; give sigma_v and K0",
            kind="consolidation", p=100.0, K0=0.5)
    refused("oedometer", f"{WHERE}.K0 = 0.5: an oedometer consolidates to sigma_v with zero radial strain (no K0)",
            kind="consolidation", sigma_v=100.0, K0=0.5)
    refused("triaxial", f"{WHERE}.duration = -1.0: must be > 0", kind="consolidation", p=100.0, duration=-1.0)


def test_history_and_records():
    st = read("triaxial", kind="consolidation", p=200.0)
    assert Consolidation.stress_target(st) == 200.0 and Consolidation.consolidation_path(st) == "isotropic"
    assert Consolidation.loading_phase(st, 100.0) == "loading" and Consolidation.loading_phase(st, 300.0) == "unloading"
    assert Consolidation.control_variable(st) == "p"
    assert "void_ratio" not in Consolidation.held_quantities(st)
    now = {"p": 100.0, "sigma_v": 100.0, "strain": 0.0, "cavity": 0.0}
    x_name, x, t, quantities = Consolidation.logged(st, "triaxial", 4, now, {}, "here")
    assert x_name == "p" and x[-1] == 200.0 and t[-1] == CONSOLIDATION_DURATION and quantities == ("void_ratio",)
    assert now == {"p": 200.0, "sigma_v": 200.0, "strain": None, "cavity": 0.0}
