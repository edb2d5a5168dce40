"""fem_cloth.batch: batch runs of randomised scenes on Dask distributed (docs/batch.md)."""
