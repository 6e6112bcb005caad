"""Constraints between parameters of a prior, such as ``kappa < lambda_``: a parameter vector violating one has zero
prior density (:class:`inference.Prior`).

An expression compares two sides with ``<``, ``<=``, ``>`` or ``>=``; each side is a product of one parameter name
and numbers, or a number, joined by ``*`` and ``/`` (a name only multiplied or divided by constants):
``"kappa < lambda_"``, ``"kappa <= 0.5 * lambda_"``, ``"M / 2 > 0.3"``. The expression is parsed into these pieces,
never evaluated as code. A callable ``{name: values (n,)} -> bool (n,)`` is taken as it is.
"""
from __future__ import annotations

import operator
import re
from dataclasses import dataclass

import numpy as np

__all__ = ["Constraint", "parse_constraint", "constraint_of"]

_TOKEN = re.compile(r"\s*(?:(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)|(?P<name>[A-Za-z_][A-Za-z_0-9]*)"
                    r"|(?P<op><=|>=|<|>|\*|/))")
_COMPARE = {"<": operator.lt, "<=": operator.le, ">": operator.gt, ">=": operator.ge}


@dataclass(frozen=True)
class Side:
    """coefficient * parameter (``name`` None: the constant ``coefficient``)."""

    coefficient: float
    name: str | None

    def value(self, theta, names):
        return self.coefficient * theta[:, names.index(self.name)] if self.name else self.coefficient


@dataclass(frozen=True)
class Constraint:
    """``left op right`` (parsed) or ``function`` (a callable); ``text`` names it in messages and reports."""

    text: str
    names: tuple
    left: Side | None = None
    op: str | None = None
    right: Side | None = None
    function: object = None

    def holds(self, theta, names) -> np.ndarray:
        """True where the constraint holds, for theta (n, d) in the order of ``names``."""
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if self.function is not None:
            values = {n: theta[:, k] for k, n in enumerate(names)}
            return np.broadcast_to(np.asarray(self.function(values), dtype=bool), (len(theta),)).copy()
        with np.errstate(invalid="ignore"):
            return np.broadcast_to(_COMPARE[self.op](self.left.value(theta, names), self.right.value(theta, names)),
                                   (len(theta),)).copy()

    def with_values(self, values: dict) -> "Constraint":
        """The parsed constraint with the parameters of ``values`` (fixed ones) replaced by their values; the text
        keeps the original expression. A callable constraint is returned unchanged."""
        if self.function is not None:
            return self

        def side(s):
            return Side(s.coefficient * values[s.name], None) if s.name in values else s

        return Constraint(self.text, tuple(n for n in self.names if n not in values), side(self.left), self.op,
                          side(self.right))

    def constant(self):
        """True or False for a parsed constraint that names no parameter (after :meth:`with_values`), else None."""
        if self.function is not None or self.names:
            return None
        return bool(_COMPARE[self.op](self.left.coefficient, self.right.coefficient))


def _side(tokens, text):
    """Tokens of one side -> Side; ValueError for anything but a name times/over numbers."""
    coefficient, name, expect_operand, op = 1.0, None, True, "*"
    for kind, tok in tokens:
        if expect_operand:
            if kind == "number":
                coefficient = coefficient * float(tok) if op == "*" else coefficient / float(tok)
            elif kind == "name":
                if name is not None or op == "/":
                    raise ValueError(f"constraint {text!r}: one parameter per side, multiplied or divided by "
                                     "numbers only")
                name = tok
            else:
                raise ValueError(f"constraint {text!r}: {tok!r} where a name or a number was expected")
        elif kind == "op" and tok in "*/":
            op = tok
        else:
            raise ValueError(f"constraint {text!r}: {tok!r} where * or / was expected")
        expect_operand = not expect_operand
    if expect_operand:
        raise ValueError(f"constraint {text!r}: a side is empty or ends with an operator")
    return Side(coefficient, name)


def parse_constraint(text: str, names) -> Constraint:
    """Parse an expression (module docstring) over the parameter ``names``; ValueError naming the expression and
    what is wrong (unknown name, no or two comparisons, a term that is not name times constants)."""
    tokens, pos = [], 0
    text = str(text)
    while pos < len(text.rstrip()):
        m = _TOKEN.match(text, pos)
        if not m or m.end() == pos:
            raise ValueError(f"constraint {text!r}: cannot read {text[pos:].strip()!r} (names, numbers, * / and one "
                             "of < <= > >=)")
        kind = m.lastgroup
        tokens.append((kind, m.group(kind)))
        pos = m.end()
    compare = [i for i, (kind, tok) in enumerate(tokens) if kind == "op" and tok in _COMPARE]
    if len(compare) != 1:
        raise ValueError(f"constraint {text!r}: expected exactly one comparison (<, <=, > or >=)")
    i = compare[0]
    left, right = _side(tokens[:i], text), _side(tokens[i + 1:], text)
    used = tuple(n for n in (left.name, right.name) if n)
    for n in used:
        if n not in names:
            raise ValueError(f"constraint {text!r}: unknown parameter {n!r}; the prior has {list(names)}")
    if not used:
        raise ValueError(f"constraint {text!r}: names no parameter")
    return Constraint(" ".join(tok for _, tok in tokens), used, left, tokens[i][1], right)


def constraint_of(value, names) -> Constraint:
    """A Constraint from a Constraint, an expression or a callable (named by its ``__name__``)."""
    if isinstance(value, Constraint):
        missing = [n for n in value.names if n not in names]
        if missing:
            raise ValueError(f"constraint {value.text!r}: unknown parameter(s) {missing}; the prior has {list(names)}")
        return value
    if isinstance(value, str):
        return parse_constraint(value, names)
    if callable(value):
        return Constraint(getattr(value, "__name__", repr(value)), tuple(names), function=value)
    raise ValueError(f"constraint {value!r}: expected an expression such as 'kappa < lambda_' or a callable")
