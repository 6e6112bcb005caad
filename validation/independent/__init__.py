"""An independent generator of concealed-effect laboratory programmes (docs/reference.md section 9: no inverse
crime): its own material-point models (:mod:`.models`), its own explicit mixed-control integrator
(:mod:`.integrator`), the programmes and hidden effects (:mod:`.programmes`), laboratory logging, noise and files
(:mod:`.recording`); the self-boring pressuremeter pairs with their own one-dimensional radial coupled-consolidation
solver (:mod:`.sbp_solver`, :mod:`.sbp_material`, :mod:`.sbp`) and an exact undrained strain-path cavity expansion
(:mod:`.sbp_exact`); the model-form controls, the plain clay written with other conventions (:mod:`.controls`);
programmes holding two effects at once and a triaxial rate-step programme (:mod:`.multi`). It imports numpy only
(scipy in :mod:`.identifiability`; no constitutive, fem, inference or cases.study code);
``python -m validation.independent --write`` regenerates validation/data/independent/ (the hidden truth in its
KEY.json), ``--write-multi`` the multi-effect cases only."""
