"""Axis labels an engineer reads without the code: the quantity's symbol and unit (sigma'_v (kPa), not
``axial_stress@relax_ocr1``), the stage in the panel's title, the parameters with their units.

Units kPa, %, s; compression positive (an extension test's axial strain and q are negative)."""
from __future__ import annotations

from cases.study.programme import split_key

__all__ = ["QUANTITY_LABELS", "ABSCISSA_LABELS", "quantity_label", "abscissa_label", "panel_title",
           "parameter_label"]

#: recorded or simulated quantity (a curve key without its stage) -> symbol (unit)
QUANTITY_LABELS = {
    "q": "q (kPa)", "p": "p' (kPa)", "mean_stress": "p' (kPa)", "excess_pore_pressure": "excess pore pressure u (kPa)",
    "u": "excess pore pressure u (kPa)", "volumetric_strain": "volumetric strain eps_v (%)",
    "void_ratio": "void ratio e (-)", "e": "void ratio e (-)", "axial_stress": "sigma'_v (kPa)",
    "radial_stress": "sigma'_h (kPa)", "axial_strain": "axial strain eps_a (%)", "stress_ratio": "q/p' (-)",
    "cavity_pressure": "total cavity pressure psi (kPa)", "pore_pressure": "pore pressure at the wall u (kPa)",
}
#: abscissa of a record (``inference.Curve.x_name``) -> symbol (unit)
ABSCISSA_LABELS = {
    "axial_strain": "axial strain eps_a (%)", "eps_a": "axial strain eps_a (%)", "time": "time t (s)",
    "stage_time": "time since the stage start t (s)", "cavity_strain": "cavity strain eps_c (%)",
    "p": "p' (kPa)", "sigma_v": "sigma'_v (kPa)",
}


def quantity_label(key: str, unit: str = "-") -> str:
    """The axis label of a curve key (``q``, ``void_ratio@swelling``): the quantity's symbol and unit; an unknown
    quantity keeps its name with ``unit``."""
    quantity, _ = split_key(key)
    return QUANTITY_LABELS.get(quantity, f"{quantity} ({unit})")


def abscissa_label(x_name: str, unit: str = "-") -> str:
    """The axis label of a record's abscissa; an unknown one keeps its name with ``unit``."""
    return ABSCISSA_LABELS.get(x_name, f"{x_name} ({unit})")


def panel_title(test: str, key: str) -> str:
    """The title of a curve's panel: the test, and the stage of a stage programme's curve."""
    _, stage = split_key(key)
    return test if stage is None else f"{test}, stage {stage}"


def parameter_label(name: str, units: dict) -> str:
    """A parameter's axis label with its unit from ``units`` {name: unit} ("-" when dimensionless or unknown)."""
    return f"{name} ({units.get(name) or '-'})"
