"""Reading one stage table as the study reader does (cases.study.reading.staged_tests.stage)."""
from __future__ import annotations

import pytest

from cases.study.checks import Checker, StudyError
from cases.study.reading.staged_tests import stage

WHERE = "tests[0].stages[1]"


def read(apparatus, **table):
    """The Stage of ``table`` (the second stage of the first test of study.toml)."""
    return stage(Checker("study.toml"), table, WHERE, 2, apparatus)


def refused(apparatus, message, **table):
    """Assert that ``table`` is refused with exactly ``message`` after the file name."""
    with pytest.raises(StudyError) as err:
        read(apparatus, **table)
    assert str(err.value) == f"study.toml: {message}"
