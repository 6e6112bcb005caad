"""Axisymmetric coupled-consolidation (Biot u-p) finite elements for the self-boring pressuremeter."""
