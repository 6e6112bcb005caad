"""The concealed-effect proofs on this project's own generator (an inverse crime: kept as regression checks of the
loop): twelve crossed triaxial tests (``lab``), seven strain rates (``rates``), two-rate pressuremeter tests (``sbp``),
and what they share (``common``)."""
