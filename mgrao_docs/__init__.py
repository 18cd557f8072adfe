"""The project's documentation (``docs/*.md`` and ``docs/img/*``), installed with the package.

``mgrao_docs/docs`` is a link to the checkout's ``docs/`` directory; building the package copies
the files it links to, so an installed (not editable) service has every page too. The service
renders them as HTML under ``/project-docs/`` (:mod:`backend.api.docpages`).
"""

from __future__ import annotations

import importlib.resources
from pathlib import Path


def docs_dir() -> Path:
    """The directory of the Markdown pages (``*.md``) and their images (``img/``)."""
    return Path(str(importlib.resources.files(__name__) / "docs"))
