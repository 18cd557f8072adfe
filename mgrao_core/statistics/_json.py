"""Numbers of the statistics' answers as JSON takes them: non-finite values as None."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any


def pair(values: Sequence[float] | None) -> list[float | None] | None:
    """Two (or more) numbers as a JSON list, each non-finite one as None; None stays None."""
    if values is None:
        return None
    return [None if v is None or not math.isfinite(v) else float(v) for v in values]


def number(value: Any) -> float | None:
    """A number as a float, or None where it is not finite."""
    value = float(value)
    return value if math.isfinite(value) else None
