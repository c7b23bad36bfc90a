"""The evaluation pipeline and its callers: gallery, material assignment, Dask."""
