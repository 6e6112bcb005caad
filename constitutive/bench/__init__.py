"""The constitutive benchmarks (:mod:`constitutive.bench.timings`): material-point and laboratory-driver timings,
``python -m constitutive.bench [WORD ...] [--list]``."""
