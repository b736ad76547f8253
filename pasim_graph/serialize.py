"""JSON-safe values: the one serialiser the command line, the studio and plugins share."""

from __future__ import annotations

import math
from typing import Any


def json_safe(x: Any) -> Any:
    """``x`` with every non-finite float (NaN: no estimate, nothing scored; inf) as None.

    JSON has no NaN or infinity. Dicts, lists and tuples are walked (tuples become lists);
    every other value is returned as it is.
    """
    if isinstance(x, dict):
        return {k: json_safe(v) for k, v in x.items()}
    if isinstance(x, list | tuple):
        return [json_safe(v) for v in x]
    return None if isinstance(x, float) and not math.isfinite(x) else x
