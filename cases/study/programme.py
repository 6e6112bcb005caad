"""The test record of a study: one :class:`TestSpec` for every test type, with its conditions.

Test types (units kPa, m, s, 1/s; compression positive):
- ``triaxial``: drained or undrained, compression or extension, consolidated isotropically (``p0``) or along K0
  (``sigma_v0``, ``K0``), sheared at the axial strain rate ``strain_rate``;
- ``oedometer_crs``: constant rate of strain from ``sigma_v0`` (``K0`` the initial sigma'_h/sigma'_v);
- ``oedometer_creep``: incremental oedometer, load stages ``stage_stress`` each ramped over ``load_time`` and held
  for ``stage_duration``, recorded at ``n_times`` log-spaced hold times per stage;
- ``sbp``: self-boring pressuremeter expansion at the cavity strain rate ``strain_rate`` from the in situ state
  (``sigma_v0``, ``K0``, pore pressure ``u0``, permeability in m/s, probe radius in m).
``e0`` is the void ratio at the start of the test (for a model whose void ratio is a parameter, the parameter).
The record holds conditions only; the recorded abscissae (strains in %, times in s) come with the observations.
"""
from __future__ import annotations

from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

__all__ = ["TestSpec", "TEST_TYPES"]

TEST_TYPES = ("triaxial", "oedometer_crs", "oedometer_creep", "sbp")


@dataclass(frozen=True)
class TestSpec:
    """One test and its conditions (units kPa, m, s, 1/s). ``file`` and ``where`` name the study file's entry (for
    messages); a test made in code leaves them empty."""

    __test__ = False  # not a pytest class

    name: str
    type: str
    file: Path | None = None
    where: str = ""
    drainage: str | None = None
    direction: str | None = None
    consolidation: str | None = None
    p0: float | None = None
    sigma_v0: float | None = None
    K0: float | None = None
    e0: float | None = None
    strain_rate: float | None = None
    substeps: int | None = None
    stage_stress: tuple = ()
    stage_duration: float | None = None
    load_time: float = 1.0
    n_times: int = 20
    u0: float | None = None
    permeability: float | None = None
    probe_radius: float | None = None
    depth: float | None = None
    curves: tuple | None = None

    @property
    def k0(self) -> float:
        """sigma'_r0 / sigma'_a0 at the start of a triaxial test (1 when isotropically consolidated)."""
        return 1.0 if self.consolidation == "isotropic" else self.K0

    @property
    def start_p(self) -> float:
        """Mean effective stress at the start of a triaxial test (kPa)."""
        return self.p0 if self.consolidation == "isotropic" else self.sigma_v0 * (1.0 + 2.0 * self.K0) / 3.0

    @property
    def start_q(self) -> float:
        """Deviator stress sigma'_a0 - sigma'_r0 at the start of a triaxial test (kPa; 0 when isotropic)."""
        if self.k0 == 1.0:
            return 0.0
        return 3.0 * self.start_p * (1.0 - self.k0) / (1.0 + 2.0 * self.k0)

    @property
    def site(self) -> dict:
        """The in situ state of an SBP test, as the pressuremeter problem takes it (kPa, m/s, m)."""
        return {"sigma_v0": self.sigma_v0, "K0": self.K0, "u0": self.u0, "permeability": self.permeability,
                "a0": self.probe_radius}

    def hold_stage(self, t):
        """Stage index and time since the stage start of records at times ``t`` (s since the test start) of an
        incremental oedometer: stage k spans (k D, (k + 1) D], loaded during its first ``load_time`` s."""
        d = self.stage_duration
        stage = np.maximum(np.ceil(np.asarray(t) / d - 1e-12).astype(int) - 1, 0)
        return stage, t - stage * d

    def conditions(self) -> dict:
        """The test conditions as plain data (for summaries and the diagnosis input)."""
        skip = ("name", "file", "where")
        return {f.name: (list(v) if isinstance(v, tuple) else v) for f in fields(self)
                for v in [getattr(self, f.name)] if f.name not in skip and v not in (None, ())}

    def describe(self) -> str:
        if self.type == "triaxial":
            start = (f"isotropic p'0 {self.p0:g} kPa" if self.consolidation == "isotropic"
                     else f"K0 {self.K0:g}, sigma'_v0 {self.sigma_v0:g} kPa")
            rate = "" if self.strain_rate is None else f", {self.strain_rate:g} 1/s"
            return f"{self.drainage} triaxial {self.direction} ({start}{rate})"
        if self.type == "oedometer_crs":
            return f"CRS oedometer (sigma'_v0 {self.sigma_v0:g} kPa, {self.strain_rate:g} 1/s)"
        if self.type == "oedometer_creep":
            return (f"incremental oedometer, stages {', '.join(f'{s:g}' for s in self.stage_stress)} kPa held "
                    f"{self.stage_duration:g} s each")
        return (f"SBP expansion (sigma'_v0 {self.sigma_v0:g} kPa, K0 {self.K0:g}, u0 {self.u0:g} kPa, "
                f"k {self.permeability:g} m/s, {self.strain_rate:g} 1/s)")
