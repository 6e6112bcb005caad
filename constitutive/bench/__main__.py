"""``python -m constitutive.bench``: :func:`constitutive.bench.timings.main`."""
from constitutive.bench.timings import main

main()
