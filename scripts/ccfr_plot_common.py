"""Shared by plot_stats.py and plot_ablation.py: the paper's four timing stages (bottom to top, as
in its timing figure) and tolerant number parsing for the project's CSV files."""
import math

TIMING = [
    ("xpbd_s", "XPBD", "#4c72b0"),
    ("broad_s", "broad phase", "#dd8452"),
    ("narrow_s", "narrow phase", "#55a868"),
    ("resolution_s", "contact resolution", "#c44e52"),
]


def parse_float(text):
    """A number, or NaN for empty, non-numeric or non-finite fields."""
    try:
        v = float(text)
    except (TypeError, ValueError):
        return math.nan
    return v if math.isfinite(v) else math.nan
