"""What every figure of the report shares: matplotlib set-up and saving, the colours of
techniques, the reference and floor (by role), and small helpers over results rows."""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

DPI = 80


def plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as pyplot
    return pyplot


def side_legend(ax, *handles_labels, fontsize=7) -> None:
    """The legend outside the panel grid, right of its top-right panel."""
    ax.legend(*handles_labels, fontsize=fontsize, loc="upper left", bbox_to_anchor=(1.02, 1.0))


def save(fig, out, name: str, tight: bool = True) -> str:
    """Lay out, write out/name and free the figure; returns the file name."""
    if tight:
        fig.tight_layout()
    fig.savefig(out / name)
    plt().close(fig)
    return name


def log_axes(ax, x=True, y=True) -> None:
    """Log scale with plain tick labels at 1, 2, 5 x 10^k (no overlapping minor labels)."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    fmt = FuncFormatter(lambda v, _: f"{v:g}")
    for on, axis, setter, lim in ((x, ax.xaxis, ax.set_xscale, ax.get_xlim),
                                  (y, ax.yaxis, ax.set_yscale, ax.get_ylim)):
        if not on:
            continue
        setter("log")
        ax.autoscale_view()
        lo, hi = sorted(lim())
        narrow = lo > 0 and hi / lo < 4       # less than a factor 4: label every 1..9 x 10^k
        axis.set_major_locator(LogLocator(base=10, subs=tuple(float(k) for k in range(1, 10))
                                          if narrow else (1.0, 2.0, 5.0)))
        axis.set_major_formatter(fmt)
        axis.set_minor_formatter(NullFormatter())


def panel_style(ax, title: str = "", xlabel: str = "", ylabel: str = "") -> None:
    if title:
        ax.set_title(title, fontsize=9)
    if xlabel:
        ax.set_xlabel(xlabel, fontsize=8)
    if ylabel:
        ax.set_ylabel(ylabel, fontsize=8)
    ax.tick_params(labelsize=7)
    ax.grid(alpha=0.3, which="both")


# ---------------------------------------------------------------------------- roles, colours

@dataclass(frozen=True)
class Roles:
    """The techniques the report treats apart, found by role: the exactness reference and
    the floor (the shading floor no technique can beat)."""
    reference: str
    floor: str

    @classmethod
    def from_registry(cls) -> "Roles":
        from ..techniques import with_role
        return cls(with_role("reference").name, with_role("floor").name)


class Colors:
    def __init__(self, techniques, roles: Roles):
        import matplotlib
        # tab20's dark half is tab10; past ten techniques its light half (tab10 repeated
        # would give the eleventh the first one's colour)
        cmap = matplotlib.colormaps["tab20"]
        shades = [2 * i for i in range(10)] + [2 * i + 1 for i in range(10)]
        self.roles = roles
        others = [t for t in techniques if t != roles.floor]
        self.c = {t: cmap(shades[i % 20]) for i, t in enumerate(others)}
        self.c[roles.floor] = (0, 0, 0, 1)

    def __call__(self, t):
        return self.c.get(t, (0.5, 0.5, 0.5, 1))

    def style(self, t):
        return dict(ls="--", marker="*") if t == self.roles.floor else dict(ls="-", marker="o")


# ---------------------------------------------------------------------------- rows

def order(rows, key):
    """The values of a column in order of first appearance (the registry's order)."""
    return list(dict.fromkeys(r[key] for r in rows))


def sel(rows, **kw):
    return [r for r in rows if all(r.get(k) == v for k, v in kw.items())]


def num(v) -> float:
    try:
        return float(v)
    except (TypeError, ValueError):
        return math.nan


def gmean(values) -> float:
    a = np.maximum(np.asarray([num(v) for v in values], np.float64), 1e-6)
    return float(np.exp(np.log(a).mean())) if len(a) else math.nan


def mean(values) -> float:
    a = np.asarray([num(v) for v in values], np.float64)
    a = a[~np.isnan(a)]
    return float(a.mean()) if len(a) else math.nan


def ms(v) -> str:
    v = num(v)
    if math.isnan(v):
        return "-"
    return f"{v:.3g} ms" if v < 100 else f"{v:.0f} ms"


def times(v) -> str:
    v = num(v)
    return "-" if math.isnan(v) else (f"{v:.3g}x" if v < 100 else f"{v:.0f}x")


def resolution(r) -> str:
    return f"{int(r['width'])}x{int(r['height'])}"
