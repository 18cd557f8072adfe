"""The web edge: the FastAPI app (:mod:`backend.api.app`), its routers, schemas, middleware and served files."""
