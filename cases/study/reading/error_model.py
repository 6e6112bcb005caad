"""The error model of a study file: the ``[sigma_eps]`` table (bounds of the error parameter and, optionally, groups
of curves each with its own error parameter, Eq. (6g) of docs/reference.md section 1).

    [sigma_eps]
    bounds = [0.002, 0.3]                     # every group's bounds unless bounds_of names it
    prior = "uniform"                         # or "log-uniform"
    groups = { volume = ["void_ratio", "volumetric_strain"], stress = ["q", "p"] }
    [sigma_eps.bounds_of]
    volume = [0.0005, 0.05]

A group member is a curve name (``q@shear3``) or a quantity name (``q``: that quantity's curve of every test and every
stage). Every calibrated curve must fall in exactly one group. Without ``groups`` one error parameter ``sigma_eps``
serves every curve (the paper's setting); with groups the parameters are ``sigma_eps_<group>``.
"""
from __future__ import annotations

from dataclasses import dataclass, field

from cases.study.checks import StudyError
from cases.study.programme import split_key

__all__ = ["ErrorModel", "read_error_model", "SIGMA_FIELDS", "DEFAULT_SIGMA"]

SIGMA_FIELDS = ("bounds", "prior", "groups", "bounds_of")
DEFAULT_SIGMA = {"bounds": [0.002, 0.3]}


@dataclass(frozen=True)
class ErrorModel:
    """bounds, kind: the error parameters' prior; groups: {group: curve or quantity names} (empty: one sigma_eps);
    bounds_of: {group: (lower, upper)} replacing ``bounds`` for that group; where: the file, for messages."""

    bounds: tuple
    kind: str = "uniform"
    groups: dict = field(default_factory=dict)
    bounds_of: dict = field(default_factory=dict)
    where: str = ""

    def parameter_bounds(self) -> dict:
        """{error parameter name: (lower, upper)} in the order of the groups."""
        if not self.groups:
            return {"sigma_eps": self.bounds}
        return {f"sigma_eps_{g}": self.bounds_of.get(g, self.bounds) for g in self.groups}

    def curve_groups(self, observations) -> dict | None:
        """{group: [(test, curve), ...]} for ``inference.Likelihood(groups=...)`` (None without groups).
        StudyError naming the curve that falls in no group or in two."""
        if not self.groups:
            return None
        out = {g: [] for g in self.groups}
        listed = "; ".join(f"{g} = {list(m)}" for g, m in self.groups.items())
        for t in observations:
            for c in t.curves:
                quantity = split_key(c)[0]
                found = [g for g, members in self.groups.items() if c in members or quantity in members]
                if len(found) != 1:
                    why = "in no group" if not found else f"in {len(found)} groups ({', '.join(found)})"
                    raise StudyError(f"{self.where}: sigma_eps.groups: test {t.name}, curve {c} is {why}; every "
                                     f"calibrated curve must be in exactly one ({listed})")
                out[found[0]].append((t.name, c))
        empty = [g for g, keys in out.items() if not keys]
        if empty:
            raise StudyError(f"{self.where}: sigma_eps.groups.{empty[0]} = {list(self.groups[empty[0]])}: names no "
                             "calibrated curve of any test")
        return out


def read_error_model(ck, table) -> ErrorModel:
    """The checked ``[sigma_eps]`` table (module docstring); errors name the file, table.field and value."""
    s = ck.table(table, "sigma_eps", SIGMA_FIELDS, ("bounds",))
    lo, hi, kind = ck.bounds({k: s[k] for k in ("bounds", "prior") if k in s}, "sigma_eps")
    if lo < 0:
        ck.fail("sigma_eps.bounds", s["bounds"], "sigma_eps must be >= 0")
    groups = {}
    for g, members in ck.table(s.get("groups", {}), "sigma_eps.groups").items():
        where = f"sigma_eps.groups.{g}"
        if not g.isidentifier():
            ck.fail(where, members, "a group name must be a plain name (letters, digits, _): it names "
                    "sigma_eps_<group>")
        if not isinstance(members, list) or not members or not all(isinstance(m, str) and m for m in members):
            ck.fail(where, members, "expected a non-empty list of curve or quantity names")
        groups[g] = tuple(members)
    if len(groups) == 1:
        ck.fail("sigma_eps.groups", s["groups"], "one group is the single sigma_eps: give two or more groups or none")
    bounds_of = {}
    for g, value in ck.table(s.get("bounds_of", {}), "sigma_eps.bounds_of").items():
        if g not in groups:
            ck.fail(f"sigma_eps.bounds_of.{g}", value,
                    f"not a group of sigma_eps.groups ({', '.join(groups) or 'none'})")
        glo, ghi, _ = ck.bounds(value, f"sigma_eps.bounds_of.{g}", kind)
        if glo < 0:
            ck.fail(f"sigma_eps.bounds_of.{g}", value, "sigma_eps must be >= 0")
        bounds_of[g] = (glo, ghi)
    return ErrorModel((lo, hi), kind, groups, bounds_of, str(ck.path))
