"""Where work runs: the task pool, local or on Dask, with resumable task files
(:mod:`~cml_edge.engine.sweep`)."""
