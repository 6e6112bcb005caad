"""The glossary at the end of every report.md: the symbols a calibration report uses, each in one line with the
equation of docs/reference.md it comes from."""
from __future__ import annotations

__all__ = ["GLOSSARY", "glossary_lines"]

#: symbol -> meaning, in the order a report uses them
GLOSSARY = {
    "sigma_eps": "the relative measurement error: U_obs = c U_num with c ~ N(1, sigma_eps^2) (Eq. (1)); identified "
                 "with the soil parameters, one per error group of curves (Eq. (6g))",
    "J_g": "the goodness of fit of one test: the mean over its curves of the mean squared relative error "
           "((U_obs - U_num) / U_obs)^2 (Eq. (5)); 0.0004 is a 2 % typical misfit",
    "beta": "the tempering exponent beta_j of stage j: the sampler moves the particles from the prior (beta = 0) "
            "to the posterior (beta = 1) through densities prior x likelihood^beta_j (docs/reference.md section 2)",
    "ln S": "the log of the mean plausibility weight of one stage (Eq. (10)); the stages' ln S_j add up to ln Z",
    "ln Z": "the log-evidence of the model class, ln p(D | class) (Eq. (2)): the larger, the better the class "
            "explains the records for its number of free parameters; differences between classes are log Bayes "
            "factors",
    "ESS": "the effective sample size of a weighted population, (sum w)^2 / sum w^2: how many equally weighted "
           "samples it is worth",
    "MAP": "the maximum a posteriori parameter set: the evaluated sample of largest prior x likelihood (Eq. (7))",
}


def glossary_lines() -> list:
    """The report's glossary section as Markdown lines."""
    return ["## Glossary", ""] + [f"- **{symbol}**: {meaning}" for symbol, meaning in GLOSSARY.items()] + [""]
