"""texdefrag batch: a whole production, resumable and fault-tolerant, locally or on Dask (docs/batch.md)."""
