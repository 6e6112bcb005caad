"""The ``[reference]`` table of a study file: published or generating parameter values shown beside the posterior
(report.md's parameter table, the marginals' marks, a sand study's CSL figure, the MAP spread of ``--runs``).

    [reference.paper_de]
    source = "paper DE-TMCMC MAP"      # the column's label in report.md and the figures
    figures = true                     # marked in the figures (false: report.md only, e.g. a standard deviation)
    M = 1.71
    sigma_p0 = 58.4                    # in the model's units (kPa)

A value is named by a parameter of the study's model or an error parameter (``sigma_eps``, ``sigma_eps_<group>``)
and is a finite number; anything else is one error naming the file, ``reference.<key>.<field>`` and the value.
"""
from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Reference", "read_references", "is_error_parameter"]


@dataclass(frozen=True)
class Reference:
    """One reference column: its key in the file, its ``source`` label, whether the figures mark it, and its
    {parameter: value}."""

    key: str
    source: str
    figures: bool
    values: dict


def is_error_parameter(name: str) -> bool:
    """sigma_eps, or sigma_eps_<group> of an error group (Eq. 6g)."""
    return name == "sigma_eps" or (name.startswith("sigma_eps_") and name[len("sigma_eps_"):].isidentifier())


def read_references(ck, table, parameters) -> dict:
    """{key: Reference} of the ``[reference]`` table in file order; ``parameters``: the model's parameter names."""
    out = {}
    for key, entry in ck.table(table, "reference").items():
        where = f"reference.{key}"
        ck.table(entry, where, None, ("source",))
        source = ck.text(entry["source"], f"{where}.source")
        figures = ck.flag(entry.get("figures", True), f"{where}.figures")
        values = {}
        for name, value in entry.items():
            if name in ("source", "figures"):
                continue
            if name not in parameters and not is_error_parameter(name):
                ck.fail(f"{where}.{name}", value, "unknown parameter; expected one of "
                        f"{', '.join(parameters)}, sigma_eps or sigma_eps_<group>")
            values[name] = ck.number(value, f"{where}.{name}")
        if not values:
            ck.fail(where, entry, "no parameter values (name = value)")
        out[key] = Reference(key, source, figures, values)
    return out
