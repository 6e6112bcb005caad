"""Reading a study file and its recordings imports no FE code (the reader is usable without the solver)."""
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[4]


def test_reading_a_study_imports_no_fe_code():
    code = ("import sys, cases.study.reading.schema, cases.study.reading.records, cases.study.stages; "
            "print(sorted(m for m in sys.modules if m == 'fem' or m.startswith('fem.')))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
