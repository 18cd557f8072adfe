"""Where the API lives in the URL space: its prefix, and the one rule for "is this path under it"."""

from __future__ import annotations

API_PREFIX = "/api"


def under(path: str, prefix: str = API_PREFIX) -> bool:
    """Whether ``path`` is ``prefix`` itself or below it (``/api`` and ``/api/jobs``, not ``/apidocs``)."""
    return path == prefix or path.startswith(prefix + "/")
