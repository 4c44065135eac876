"""Randomized campaigns: seeded cases, one experiment spec per (case, method), metrics per run.

:mod:`.cases` generates the cases of a family from a seed, :mod:`.spec` holds the data that
identifies one run (:class:`~.spec.ExperimentSpec`, with a stable key), :mod:`.metrics` turns
a finished run into one table row, and :func:`~.run.run_spec` runs one spec anywhere (a Dask
worker included) and always returns a row, recording an error instead of raising.
"""
