"""Measured spread: what the report may call a finding.  Each timed row carries the median,
min and max of its samples; a difference between two timings is a finding only when one's
max lies below the other's min.  One sample measures no spread, so nothing measured once is
ranked as a finding; the report then says "within spread" (or that there was one sample).
"""
from __future__ import annotations

from dataclasses import dataclass
import math

import numpy as np

from .common import ms, num


@dataclass(frozen=True)
class Spread:
    med: float
    lo: float
    hi: float
    n: int            # the fewest samples behind any of the values

    @classmethod
    def of(cls, row, base: str) -> "Spread":
        """From a row's `<base>_ms`, `<base>_min_ms`, `<base>_max_ms` and `samples`."""
        med = num(row[f"{base}_ms"])
        lo, hi = num(row.get(f"{base}_min_ms", med)), num(row.get(f"{base}_max_ms", med))
        n = num(row.get("samples", 1))
        return cls(med, med if math.isnan(lo) else lo, med if math.isnan(hi) else hi,
                   1 if math.isnan(n) else int(n))

    @classmethod
    def mean(cls, spreads) -> "Spread":
        s = list(spreads)
        return cls(*(float(np.mean([getattr(x, k) for x in s])) for k in ("med", "lo", "hi")),
                   min(x.n for x in s))

    @classmethod
    def gmean(cls, spreads) -> "Spread":
        s = list(spreads)
        g = lambda k: float(np.exp(np.mean(np.log([max(getattr(x, k), 1e-6) for x in s]))))
        return cls(g("med"), g("lo"), g("hi"), min(x.n for x in s))

    def ratio(self, other: "Spread") -> "Spread":
        """self / other, its range from the two ranges."""
        d = lambda v: max(v, 1e-12)
        return Spread(self.med / d(other.med), self.lo / d(other.hi), self.hi / d(other.lo),
                      min(self.n, other.n))


def spread_cell(row, base: str, digits: int = 2) -> str:
    """A table cell of a row's median with its [min-max] ("" where there is none)."""
    s = Spread.of(row, base)
    return "" if math.isnan(s.med) else f"{s.med:.{digits}f} [{s.lo:.{digits}f}-{s.hi:.{digits}f}]"


def below(a: Spread, b: Spread) -> bool:
    """a is lower than b beyond the measured spread (both measured more than once)."""
    return a.n > 1 and b.n > 1 and a.hi < b.lo


def lowest(cands: dict) -> tuple[object, list]:
    """(the key of the lowest median, the keys within its spread, lowest median first)."""
    best = min(cands, key=lambda k: cands[k].med)
    rivals = sorted((k for k in cands if k != best and not below(cands[best], cands[k])),
                    key=lambda k: cands[k].med)
    return best, rivals


def lowest_phrase(cands: dict, what: str, label=str) -> str:
    """"<what> is lowest at X (1.2 ms)" when X's max is below every other's min, else
    "<what> has its lowest median at X (1.2 ms), within spread of Y, Z"."""
    best, rivals = lowest(cands)
    s = cands[best]
    if not rivals:
        return f"{what} is lowest at {label(best)} ({ms(s.med)}, {ms(s.lo)}-{ms(s.hi)})"
    if min(c.n for c in cands.values()) < 2:
        return f"{what} has its lowest value at {label(best)} ({ms(s.med)}; one sample: no spread measured)"
    return (f"{what} has its lowest median at {label(best)} ({ms(s.med)}), within spread of "
            f"{', '.join(label(k) for k in rivals)}")


def ratio_phrase(r: Spread) -> str:
    """A ratio and whether it is a finding: above or below 1 beyond the spread."""
    v = f"{r.med:.3g}x"
    if r.n < 2:
        return f"{v} (one sample)"
    if r.lo > 1.0:
        return f"{v} (higher beyond spread, {r.lo:.3g}-{r.hi:.3g}x)"
    if r.hi < 1.0:
        return f"{v} (lower beyond spread, {r.lo:.3g}-{r.hi:.3g}x)"
    return f"{v} (within spread, {r.lo:.3g}-{r.hi:.3g}x)"
