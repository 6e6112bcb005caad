"""The sand room of the constitutive models: SIMSAND (:mod:`constitutive.sand.simsand`), its constants, its numpy
stress-point integrator and its compiled kernel."""
