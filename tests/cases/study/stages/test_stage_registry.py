"""The stage-kind registry (cases.study.stages.KINDS): every kind in one class, each apparatus's kinds in the order
the messages list them, kind names only in the stage modules, and no FE code imported."""
from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from cases.study.stages import KINDS, ORDER, Stage, StageKind, kind_named

ROOT = Path(__file__).resolve().parents[4]


def test_each_apparatus_runs_its_kinds_in_order():
    assert {a: tuple(k) for a, k in KINDS.items()} == {
        "triaxial": ("consolidation", "shear", "creep", "relaxation", "crs"),
        "oedometer": ("consolidation", "creep", "relaxation", "crs", "load"),
        "sbp": ("expansion", "hold", "unloading")}


def test_a_stage_finds_its_kind():
    for kind in ORDER:
        assert issubclass(kind, StageKind) and kind_named(kind.name) is kind
        assert Stage(kind.name, "s").procedure is kind
    with pytest.raises(KeyError):
        Stage("torsion", "t").procedure


def test_laboratory_kinds_have_controls_for_their_apparatus():
    for apparatus in ("triaxial", "oedometer"):
        for kind in KINDS[apparatus].values():
            assert kind.controls[apparatus].shape == (6,)
    for kind in KINDS["sbp"].values():
        assert kind.controls == {} and hasattr(kind, "fe_phase")


def test_kind_names_are_written_in_the_stage_modules_only():
    """Outside cases/study/stages no code compares a stage's kind, and a kind name in quotes is user-facing text
    (docstrings, comments) -- except "consolidation" and "hold", which also name the flat triaxial field, a covariate
    and a loading phase."""
    names = "|".join(kind.name for kind in ORDER if kind.name not in ("consolidation", "hold"))
    pattern = re.compile(rf'"({names})"|\b(stage|st|s)\.kind (==|!=|in|not in) ')
    found = []
    for path in (ROOT / "cases" / "study").rglob("*.py"):
        if "stages" in path.parts:
            continue
        code = re.sub(r'"""[\s\S]*?"""', "", path.read_text())
        found += [f"{path.relative_to(ROOT)}: {line.strip()}" for line in code.splitlines()
                  if pattern.search(line) and not line.strip().startswith("#")]
    assert found == []


def test_the_stage_kinds_import_no_fe_code():
    code = ("import sys, cases.study.stages, cases.study.stages.sequence; "
            "print(sorted(m for m in sys.modules if m == 'fem' or m.startswith('fem.')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
