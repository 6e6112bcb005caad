"""Constants of SIMSAND shared by the model (:mod:`constitutive.sand.simsand`), its numpy integrator
(:mod:`constitutive.sand.substepping`) and its compiled kernel (``constitutive.sand._simsand_kernel``).

Plain Python (no numpy, no numba) so that every one of them can import it without import circles. The compiled
kernel freezes ``E_MAX_STIFFNESS`` into its cached machine code: after changing it, delete the kernel cache
(:mod:`constitutive.jit`).
"""

#: atmospheric pressure (kPa), the reference pressure of (III) and (VI)
P_AT = 101.325
#: void ratio at which the stiffness of (III) vanishes
E_MAX_STIFFNESS = 2.97
#: mixed control fails (IntegrationError) where the tangent on the stress-controlled components falls below this
#: fraction of the elastic one: the path (e.g. drained triaxial with extreme dilatancy) is about to become
#: uncontrollable and the lateral strain rate unbounded
CONTROL_STIFFNESS_RATIO = 1e-2
#: the relative stress error of a substep is measured against max(|sigma'|, this fraction of p_at) so that states
#: near the tension cutoff (liquefied sand) do not demand vanishing substeps
STRESS_ERROR_FLOOR = 1e-2
#: why a point failed, by the integrators' failure code (1-6; 0: none; ``_simsand_kernel`` names the codes)
FAILURE_REASONS = (
    None,
    "a:D m + K_p <= 0 (no unique plastic response)",
    "mixed control lost: the tangent stiffness on the stress-controlled components fell below {ratio} of the elastic "
    "one (uncontrollable path)",
    "mixed control lost within the substep: the tangent stiffness on the stress-controlled components fell below "
    "{ratio} of the elastic one",
    "drift correction failed (no free stress component changes f)",
    f"void ratio outside (0, {E_MAX_STIFFNESS}) or non-finite stress",
    "error control cannot be met (substep below 1e-12 of the increment or more than {max_substeps} substeps)",
)
