"""One style for every figure pfbench draws: sizes and fonts, a colour and line style per filter,
axis labels from a table of names and units (never a raw key), legends outside the data, and the
file formats (PNG, SVG, PDF), each written with fixed metadata so that the same figure gives the
same bytes.
"""
from __future__ import annotations

import re
from pathlib import Path

from .fsutil import write_through_temp

FORMATS = ("png", "svg", "pdf")
DPI = 150
# Every figure is read at a page width of 1400 px: at most MAX_WIDTH_IN inches wide (1400 px at
# DPI), so a page shows it at its size or larger, and no text under MIN_FONT_PT points.
MAX_WIDTH_IN = 1400 / DPI
MIN_FONT_PT = 8.0

# The look of every figure (matplotlib's rcParams), applied with ``style()``.
RC = {
    "font.size": 9, "axes.titlesize": 9.5, "axes.labelsize": 9, "legend.fontsize": 8.5,
    "xtick.labelsize": 8.5, "ytick.labelsize": 8.5, "figure.titlesize": 10, "axes.grid": True, "grid.alpha": 0.3,
    "axes.spines.top": False, "axes.spines.right": False, "figure.dpi": 100,
    "savefig.bbox": "tight", "savefig.pad_inches": 0.08,
    "svg.hashsalt": "pfbench",          # fixed element ids in SVG: the same figure, the same bytes
    "svg.fonttype": "none",             # text stays text in SVG (searchable, smaller)
    "pdf.fonttype": 42,
}

# Fixed metadata per format: no dates, no software versions.
_META = {"png": {"Software": None}, "svg": {"Date": None, "Creator": None},
         "pdf": {"CreationDate": None, "ModDate": None, "Producer": None, "Creator": None}}

# A filter's colour, by its place in the experiment (the same in every figure of it), and a line
# style and marker that tell it apart without colour.
PALETTE = ("#1f77b4", "#d62728", "#2ca02c", "#ff7f0e", "#9467bd", "#8c564b", "#e377c2",
           "#17becf", "#7f7f7f", "#bcbd22")
LINESTYLES = ("-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)))
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*", "<", ">")

# Names and units of what figures put on an axis: metrics (pfbench.metrics), the statistics
# around them, and configuration keys a sweep may vary (the last part of the key).
LABELS = {
    "rmse": "RMSE", "mse": "MSE", "heading_rmse": "heading RMSE (rad)",
    "position_error": "position error (m)", "heading_error": "heading error (rad)",
    "x_error": "x error (m)", "y_error": "y error (m)", "final_error": "final position error (m)",
    "error_at_step": "position error at the report step (m)",
    "converged": "converged (fraction of trials)", "converge_step": "steps to converge",
    "recovery_steps": "steps to recover", "recovery_failures": "kidnappings not recovered",
    "mean_particles": "mean particle count", "landmark_error": "landmark error (m)",
    "association_errors": "wrong associations (fraction)",
    "dropped_frac": "dropped observations (fraction)", "map_duplicates": "duplicate landmarks",
    "mean_ess": "mean effective sample size", "resample_count": "resampling steps",
    "diversity_l1": "diversity after resampling", "distinct_frac": "distinct particles (fraction)",
    "lik_evals_per_step": "likelihood evaluations per step", "wall_s": "wall time per trial (s)",
    "particles": "particles N", "speed_mps": "robot speed (m/s)", "steps": "time steps T",
    "process_noise_var": "process noise variance Q",
    "measurement_noise_var": "measurement noise variance R",
    "bearing_noise_deg": "bearing noise (deg)", "range_noise_m": "range noise (m)",
    "iterations": "swarm iterations", "neff_ratio": "resampling threshold (fraction of N)",
    "max_range_m": "sensor range (m)", "beacons": "beacons",
}
# Units a key's name ends in, for a key the table does not name.
_UNITS = (("_mps", "m/s"), ("_deg", "deg"), ("_rad", "rad"), ("_m", "m"), ("_s", "s"),
          ("_hz", "Hz"))


def label(key: str, unit: str = "") -> str:
    """An axis label for a metric or a configuration key ('scenario.speed_mps' -> 'robot speed
    (m/s)'); ``unit``: the unit of a metric whose unit the scenario decides (an RMSE in m)."""
    last = key.split(".")[-1].split("@")[0]
    if last in LABELS:
        text = LABELS[last]
        return f"{text} ({unit})" if unit and "(" not in text else text
    for suffix, u in _UNITS:
        if last.endswith(suffix):
            return f"{last[:-len(suffix)].replace('_', ' ')} ({u})"
    return re.sub(r"_+", " ", last)


def width(inches: float) -> float:
    """A figure's width in inches, at most MAX_WIDTH_IN (what a 1400 px page shows unscaled)."""
    return min(float(inches), MAX_WIDTH_IN)


def wrap(text: str, inches: float, size: float = 10.0) -> str:
    """``text`` broken into lines that fit ``inches`` at ``size`` points (a title of a figure
    that width; a line break already in the text is kept)."""
    import textwrap
    chars = max(30, int(inches * 72 / (0.52 * size)))
    return "\n".join(textwrap.fill(part, chars) for part in text.split("\n"))


def legibility(fig) -> list[str]:
    """What keeps ``fig`` from being read at a 1400 px page width: wider than MAX_WIDTH_IN, or a
    visible text (title, label, tick label, legend entry, note) under MIN_FONT_PT points; [] when
    nothing does."""
    out = []
    w = fig.get_size_inches()[0]
    if w > MAX_WIDTH_IN + 1e-9:
        out.append(f"{w:.2f} in wide, more than {MAX_WIDTH_IN:.2f}")
    from matplotlib.text import Text
    for t in fig.findobj(Text):
        if t.get_visible() and t.get_text().strip() and t.get_fontsize() < MIN_FONT_PT - 1e-9:
            out.append(f"text {t.get_text()[:30]!r} at {t.get_fontsize():g} pt")
    return out


def lognormal_band(mean, se, level: float = 0.95):
    """(low, high) of a positive quantity's mean: the interval mean exp(-+z se/mean) (z the
    normal quantile of ``level``): the normal interval of log(mean), whose standard error is
    se/mean by the delta method, taken back; it stays above 0 where the normal interval
    mean -+ z se can dip below it (a run time). Arrays in, arrays out; NaN where mean <= 0."""
    import numpy as np
    from scipy.stats import norm
    mean = np.asarray(mean, dtype=float)
    se = np.asarray(se, dtype=float)
    z = norm.ppf(0.5 + level / 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        f = np.where(mean > 0, np.exp(z * se / mean), np.nan)
        return mean / f, mean * f


def colour(i: int) -> str:
    return PALETTE[i % len(PALETTE)]


def linestyle(i: int):
    return LINESTYLES[i % len(LINESTYLES)]


def marker(i: int) -> str:
    return MARKERS[i % len(MARKERS)]


def pyplot():
    """matplotlib.pyplot on the Agg backend, imported on first use: a command that draws no
    figure never imports matplotlib (most of a second)."""
    import sys
    if "matplotlib.pyplot" not in sys.modules:
        import matplotlib
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def style():
    """The context in which every figure is drawn (``with style(): ...``)."""
    return pyplot().rc_context(RC)


def legend_outside(ax, **kw):
    """The legend to the right of the axes, outside the data; returns it (None without labels)."""
    handles, labels = ax.get_legend_handles_labels()
    if not handles:
        return None
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0,
                     frameon=False, **kw)


def legend_below(fig, axes, ncol: int = 3, **kw):
    """One legend for a figure, under its axes (a figure of panels that share their lines)."""
    handles, labels = axes[0].get_legend_handles_labels()
    if not handles:
        return None
    return fig.legend(handles, labels, loc="lower center", ncol=ncol, frameon=False,
                      bbox_to_anchor=(0.5, 0.0), **kw)


def prune(folder: Path, keep: list[Path]) -> None:
    """Remove the figures in ``folder`` (files of FORMATS) that are not in ``keep``: those of
    another format, or no longer drawn; a folder holds one format."""
    folder = Path(folder)
    for old in (folder.iterdir() if folder.is_dir() else ()):
        if old.suffix.lstrip(".") in FORMATS and old not in keep:
            old.unlink()


def save(fig, path: Path) -> Path:
    """Save ``fig`` to ``path`` in the format its suffix names (.png, .svg, .pdf), through a
    temporary file, with fixed metadata; close it; return the path."""
    path = Path(path)
    fmt = path.suffix.lstrip(".")
    if fmt not in FORMATS:
        raise ValueError(f"{path}: a figure is one of {', '.join(FORMATS)}")
    try:
        with pyplot().rc_context(RC):
            write_through_temp(path, lambda tmp: fig.savefig(tmp, format=fmt, dpi=DPI,
                                                             metadata=_META[fmt]),
                               path.suffix)
    finally:
        pyplot().close(fig)
    return path
