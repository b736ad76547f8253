"""Student's t interval of a mean: the study's intervals across seeds, and across the beams
whose peak sidelobes the study measures. (A module of its own: the runner's antenna
measurement and the scores both use it, and the scores import the runner.)"""

from __future__ import annotations

import math

import numpy as np


def t_interval(values: list[float]) -> list[float]:
    from scipy import stats

    v = np.asarray(values, dtype=float)
    half = stats.t.ppf(0.975, v.size - 1) * v.std(ddof=1) / math.sqrt(v.size)
    return [float(v.mean() - half), float(v.mean() + half)]
