"""Validation of the diagnosis, run from the checkout and never installed with the package: the independent
generator of concealed-effect programmes (``validation.independent``), its data (``validation/data``) and the
concealed-effect proofs on this project's own generator (``validation.proofs``, ``python -m validation.concealed``)."""
