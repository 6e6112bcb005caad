"""Runnable studies: ``python -m cases.<name> [--quick] [--method de|o] [--samples N] [--seed S] [--out DIR]``."""
