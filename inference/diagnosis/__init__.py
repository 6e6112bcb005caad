"""Missing-physics diagnosis of a calibration: locate the mismatch, explain it, enrich, compare by the evidence.

Modules, in the order of the loop:
- ``screening``: relative residuals at the MAP, the four structure tests per curve with Holm's family-wise error, the
  mismatch regions and the covariate attribution (`screen`, `ScreenReport`);
- ``bands``: posterior predictive bands (`predictive_bands`); ``structure``: the structure tests and `segment`;
- ``attribution``: which covariate explains the residual (`attribute`, `holm`; declared specs `split_spec`);
- ``contrast``: few-test contrasts of 2-4 tests on a common abscissa (paired levels, trends);
- ``records``: the records: `ModelClass` (a calibrated class), `DecisionRule` (what confirms an enrichment),
  `MismatchRegion`, `SignatureItem`, `CandidateScore`, `Conclusion`, `Diagnosis` (with its JSON, `to_json`/`from_json`);
- ``rank``: candidate physics scored by their residual signatures, the conclusion by the Bayes factor;
- ``report``: `diagnose` (every class screened, candidates ranked, conclusion) as a `Diagnosis`, its Markdown report;
- ``files``: the run-directory files (`write_input`, `read_input`, `diagnose_directory`);
- ``loop``: `run_loop(problem)`, the calibrate -> diagnose loop in memory over a `LoopProblem`, step by step;
- ``chain``: the chain of a stepwise discovery (each step's confirmed class, ln B, the misfit left per curve);
- ``__main__``: ``python -m inference.diagnosis DIR``, the diagnosis of a finished run directory;
- ``bench``: ``python -m inference.diagnosis.bench``, the time of a screening.
"""
from .attribution import KINDS, SCOPES, Attribution, attribute, expand_covariates, holm, per_curve, split_spec
from .bands import PredictiveBand, predictive_bands
from .chain import chain_markdown, chain_steps, misfit_per_curve
from .files import diagnose_directory, read_input, recorded_rule, write_diagnosis, write_input
from .loop import ENRICH, MODEL_FORM, LoopProblem, LoopResult, run_loop
from .rank import conclude, rank_candidates
from .records import (
                      NOT_REFINED,
                      STRONG_LOG_BAYES,
                      CandidateDecision,
                      CandidateScore,
                      ClassSummary,
                      Conclusion,
                      DecisionRule,
                      DiagnosedCandidate,
                      Diagnosis,
                      MismatchRegion,
                      ModelClass,
                      NextTest,
                      SignatureItem,
)
from .report import diagnose, markdown
from .screening import (
                      POSITION,
                      CurveStatistics,
                      ScreenReport,
                      curve_statistics,
                      relative_residuals,
                      screen,
                      simulate_samples,
)
from .structure import Region, lag1_test, runs_test, scale_test, scan_test, segment

__all__ = [
    "KINDS", "SCOPES", "Attribution", "attribute", "expand_covariates", "holm", "per_curve", "split_spec",
    "PredictiveBand", "predictive_bands", "chain_markdown", "chain_steps", "misfit_per_curve",
    "diagnose_directory", "read_input", "recorded_rule", "write_diagnosis", "write_input", "ENRICH", "MODEL_FORM",
    "LoopProblem", "LoopResult", "run_loop", "conclude", "rank_candidates", "NOT_REFINED", "STRONG_LOG_BAYES",
    "CandidateDecision", "CandidateScore", "ClassSummary", "Conclusion", "DecisionRule", "DiagnosedCandidate",
    "Diagnosis", "MismatchRegion", "ModelClass", "NextTest", "SignatureItem", "diagnose", "markdown", "POSITION",
    "CurveStatistics", "ScreenReport", "curve_statistics", "relative_residuals", "screen", "simulate_samples",
    "Region", "lag1_test", "runs_test", "scale_test", "scan_test", "segment",
]
