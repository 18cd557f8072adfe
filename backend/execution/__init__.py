"""The processes that run jobs: a local worker, the Dask dispatcher, and the lifecycle both hold jobs through."""
