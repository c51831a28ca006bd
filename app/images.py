"""Images a person looks at, defined once for capture, the window and the report (the GLSL
twins of these functions are glsl/present_common.glsl; tests/app/window/test_present.py
checks that both give the same pixels):

    display    tonemap(exposure * radiance + ambient * albedo): the shaded image
    exposure   automatic: the EXPOSURE_PERCENTILE of the lit pixels' luminance maps to
               EXPOSURE_TARGET, read from a log2 luminance histogram (HIST_*)
    heat map   a per-pixel count on the turbo ramp (polynomial fit, so GLSL and Python
               agree bit for bit) with a log scale t = log2(1 + n) / log2(1 + max): max is a
               fixed number (--heat-max) or the frame's largest count; sky black, covered
               pixels with a zero count dark grey; a colour bar names the scale

plus the classification map (tree paper figure 3) and block means.

Why the ambient term sits outside the exposure: an ambient light in radiance units would be
scaled up with the exposure on a dark frame and drown the lights it is meant to show the way
to; added after the exposure, it stays the same faint floor (AMBIENT of the albedo) on every
frame, so geometry is visible with few lights (or none) and the lit image is unchanged in
proportion.  The dump's `image` is never touched: this is display only.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from PIL import Image

LUMA = np.array([0.2126, 0.7152, 0.0722], np.float32)
AMBIENT = 0.02                 # default ambient, a fraction of the albedo added after exposure
EXPOSURE_PERCENTILE = 0.95     # of the lit pixels' luminance ...
EXPOSURE_TARGET = 1.5          # ... mapped to this (Reinhard: display 0.6 before gamma, 0.8 after)
EXPOSURE_RANGE = (2.0 ** -20, 2.0 ** 20)
HIST_BINS = 128                # log2 luminance histogram of the lit pixels
HIST_LOG2_MIN = -24.0
HIST_LOG2_MAX = 16.0
HEAT_ZERO = 0.07               # covered pixel with a zero count (grey), sky is black
HEAT_OVERLAY_ALPHA = 0.6       # heat over the shaded image (overlay mode)


# ---- tone mapping ---------------------------------------------------------------------------

def to8(x: np.ndarray) -> np.ndarray:
    """[0, 1] floats -> uint8 as a GL framebuffer stores them (round to nearest)."""
    return (np.clip(x, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def tonemap_float(x: np.ndarray) -> np.ndarray:
    """Reinhard x / (1 + x), gamma 1/2.2 (present_common.glsl tonemap)."""
    x = np.nan_to_num(np.maximum(np.asarray(x, np.float32), 0.0))
    return np.power(x / (1.0 + x), 1.0 / 2.2)


def tonemap(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> 8-bit (Reinhard, gamma 2.2), exposure 1 and no ambient."""
    return to8(tonemap_float(image))


def display(image: np.ndarray, albedo: np.ndarray | None = None, exposure: float = 1.0,
            ambient: float = AMBIENT) -> np.ndarray:
    """The shaded image as shown: tonemap(exposure * radiance + ambient * albedo), uint8."""
    x = np.float32(exposure) * np.asarray(image, np.float32)
    if albedo is not None and ambient > 0:
        x = x + np.float32(ambient) * np.asarray(albedo, np.float32)
    return to8(tonemap_float(x))


def luminance(image: np.ndarray) -> np.ndarray:
    return np.asarray(image, np.float32) @ LUMA


def hist_bin(y: np.ndarray) -> np.ndarray:
    """The histogram bin of luminance y > 0 (clamped to the range's end bins)."""
    scale = HIST_BINS / (HIST_LOG2_MAX - HIST_LOG2_MIN)
    b = np.floor((np.log2(np.asarray(y, np.float32)) - np.float32(HIST_LOG2_MIN)) * np.float32(scale))
    return np.clip(b, 0, HIST_BINS - 1).astype(np.int64)


def luminance_histogram(image: np.ndarray, covered: np.ndarray) -> np.ndarray:
    """(HIST_BINS,) counts of log2 luminance over covered pixels with luminance > 0."""
    y = luminance(image)[covered]
    y = y[y > 0]
    return np.bincount(hist_bin(y), minlength=HIST_BINS).astype(np.int64)


def exposure_from_histogram(hist) -> float:
    """EXPOSURE_TARGET / the EXPOSURE_PERCENTILE luminance of the histogram (interpolated
    within its bin, in log2); 1.0 when no pixel is lit."""
    hist = np.asarray(hist, np.float64)
    total = hist.sum()
    if total <= 0:
        return 1.0
    want = EXPOSURE_PERCENTILE * total
    cum = np.cumsum(hist)
    k = int(np.searchsorted(cum, want))
    k = min(k, HIST_BINS - 1)
    before = cum[k - 1] if k > 0 else 0.0
    frac = (want - before) / hist[k] if hist[k] > 0 else 0.0
    width = (HIST_LOG2_MAX - HIST_LOG2_MIN) / HIST_BINS
    log_y = HIST_LOG2_MIN + (k + frac) * width
    lo, hi = EXPOSURE_RANGE
    return float(min(max(EXPOSURE_TARGET / 2.0 ** log_y, lo), hi))


def auto_exposure(image: np.ndarray, covered: np.ndarray) -> float:
    return exposure_from_histogram(luminance_histogram(image, covered))


# ---- heat maps --------------------------------------------------------------------------------

_KR = (0.13572138, 4.61539260, -42.66032258, 132.13108234, -152.94239396, 59.28637943)
_KG = (0.09140261, 2.19418839, 4.84296658, -14.18503333, 4.27729857, 2.82956604)
_KB = (0.10667330, 12.64194608, -60.58204836, 110.36276771, -89.90310912, 27.34824973)


def turbo(t) -> np.ndarray:
    """Turbo colour ramp (Mikhailov 2019, polynomial fit), t in [0, 1] -> (..., 3) floats."""
    t = np.clip(np.asarray(t, np.float32), 0.0, 1.0)
    powers = [np.ones_like(t), t, t * t, t * t * t, t ** 4, t ** 5]
    out = [sum(np.float32(k) * p for k, p in zip(ks, powers)) for ks in (_KR, _KG, _KB)]
    return np.clip(np.stack(out, -1), 0.0, 1.0)


def heat_t(values, vmax: float) -> np.ndarray:
    """The heat scale: log2(1 + n) / log2(1 + max), clamped to [0, 1]."""
    v = np.maximum(np.asarray(values, np.float32), 0.0)
    return np.clip(np.log2(1.0 + v) / np.float32(math.log2(1.0 + max(float(vmax), 1.0))), 0.0, 1.0)


def heat_top(largest: float, fixed: float | None = None) -> float:
    """The top of the scale, the one rule of capture, the window and the report: `fixed`
    when given (> 0), else the largest count shown, at least 1."""
    return float(fixed) if fixed else float(max(largest, 1))


def heat_max(values, covered, fixed: float | None = None) -> float:
    """The top of the scale of a per-pixel count (heat_top of its largest covered value)."""
    v = np.asarray(values)[covered] if covered is not None else np.asarray(values)
    return heat_top(int(v.max(initial=0)), fixed)


def maps_top(maps) -> float:
    """One scale over all of a technique's maps ({name: (values, label)} or {name: values}),
    so that they compare (fptl's coarse lists against its pruned ones)."""
    arrays = [m[0] if isinstance(m, tuple) else m for m in maps.values()]
    return heat_top(max([float(np.max(v)) for v in arrays if np.size(v)] + [0.0]))


def cells_to_pixels(values, size: tuple[int, int]) -> np.ndarray:
    """A per-cell map (rows, cols) over the (w, h) pixels its cells cover, row 0 = top."""
    w, h = size
    v = np.asarray(values)
    ky, kx = -(-h // v.shape[0]), -(-w // v.shape[1])
    return np.repeat(np.repeat(v, ky, 0), kx, 1)[:h, :w]


def heat_rgb(values, covered, vmax: float) -> np.ndarray:
    """(H, W, 3) uint8 heat map of per-pixel counts (present.frag's heat view)."""
    v = np.asarray(values)
    rgb = turbo(heat_t(v, vmax))
    rgb[covered & (v == 0)] = HEAT_ZERO
    rgb[~covered] = 0.0
    return to8(rgb)


def heat_ticks(vmax: float) -> list[float]:
    """Colour-bar labels: 0, 1-2-5 steps, and the top of the scale, at least 0.09 of the
    bar apart."""
    vmax = max(float(vmax), 1.0)
    steps, k = [], 0
    while (v := (1, 2, 5)[k % 3] * 10 ** (k // 3)) < vmax:
        steps.append(float(v))
        k += 1
    t = lambda v: float(heat_t(np.array([v]), vmax)[0])
    keep = [0.0]
    for v in steps:
        if t(v) - t(keep[-1]) >= 0.09 and 1.0 - t(v) >= 0.09:
            keep.append(v)
    return keep + [vmax]


def fmt_tick(v: float) -> str:
    return f"{v:.0f}" if v >= 10 or float(v).is_integer() else f"{v:.2g}"


def heat_cmap(zero_grey: bool = False):
    """The turbo ramp as a matplotlib colormap (the report's figures); zero_grey: masked
    values (a zero count, np.ma.masked_less_equal) grey as the window shows them."""
    from matplotlib.colors import ListedColormap
    cmap = ListedColormap(turbo(np.linspace(0.0, 1.0, 256)), name="lab_turbo")
    return cmap.with_extremes(bad=(HEAT_ZERO,) * 3) if zero_grey else cmap


def heat_bar_ticks(bar, vmax: float) -> None:
    """A matplotlib colour bar's ticks and labels, as the window's and capture's bars."""
    ticks = heat_ticks(vmax)
    bar.set_ticks(ticks, labels=[fmt_tick(v) for v in ticks])


def heat_norm(vmax: float):
    """The heat scale as a matplotlib norm, so a report's colour bar reads in counts."""
    from matplotlib.colors import FuncNorm
    top = math.log2(1.0 + max(float(vmax), 1.0))
    return FuncNorm((lambda v: np.log2(1.0 + np.maximum(v, 0.0)) / top,
                     lambda t: np.exp2(np.asarray(t) * top) - 1.0), vmin=0.0, vmax=float(vmax))


def _font(px: int):
    from PIL import ImageFont
    try:
        return ImageFont.load_default(size=px)
    except TypeError:      # Pillow < 10.1: bitmap font only
        return ImageFont.load_default()


def colorbar(height: int, vmax: float, label: str, width: int = 96) -> np.ndarray:
    """(height, width, 3) uint8: a vertical bar of the heat ramp (top = max) with its ticks."""
    from PIL import ImageDraw
    img = Image.new("RGB", (width, height), (255, 255, 255))
    d = ImageDraw.Draw(img)
    px = max(8, min(12, height // 12))
    font = _font(px)
    top, bottom = px, height - px
    bar_x0, bar_x1 = 6, 20
    span = max(bottom - top, 1)
    for y in range(top, bottom + 1):
        c = to8(turbo(1.0 - (y - top) / span))
        d.line([(bar_x0, y), (bar_x1, y)], fill=tuple(int(v) for v in c))
    for v in heat_ticks(vmax):
        y = bottom - float(heat_t(np.array([v]), vmax)[0]) * span
        d.line([(bar_x1, y), (bar_x1 + 3, y)], fill=(0, 0, 0))
        d.text((bar_x1 + 5, y - px / 2 - 1), fmt_tick(v), font=font, fill=(0, 0, 0))
    if height >= 80:        # the label, written downwards beside the ticks
        text = Image.new("RGB", (height, px + 4), (255, 255, 255))
        ImageDraw.Draw(text).text((2, 1), label, font=font, fill=(60, 60, 60))
        img.paste(text.rotate(-90, expand=True), (width - px - 5, 0))
    return np.asarray(img)


def save_heatmap(values: np.ndarray, path, covered: np.ndarray | None = None,
                 vmax: float | None = None, label: str = "lights evaluated / pixel") -> float:
    """The heat map as the window's heat view shows it, pixel for pixel (left), and its
    colour bar (right).  Returns the top of the scale used."""
    values = np.asarray(values)
    if covered is None:
        covered = np.ones(values.shape, bool)
    top = heat_max(values, covered, vmax)
    heat = heat_rgb(values, covered, top)
    bar = colorbar(values.shape[0], top, label + " (log)")
    Image.fromarray(np.concatenate([heat, bar], 1)).save(path)
    return top


def save_png(image: np.ndarray, path, albedo=None, exposure: float = 1.0,
             ambient: float = AMBIENT) -> None:
    Image.fromarray(display(image, albedo, exposure, ambient)).save(path)


def block_mean(values: np.ndarray, block: int = 16) -> np.ndarray:
    """Mean of `values` over block x block squares (partial blocks at the edges included)."""
    h, w = values.shape
    bh, bw = -(-h // block), -(-w // block)
    padded = np.zeros((bh * block, bw * block), np.float64)
    count = np.zeros_like(padded)
    padded[:h, :w] = values
    count[:h, :w] = 1
    s = padded.reshape(bh, block, bw, block).sum((1, 3))
    n = count.reshape(bh, block, bw, block).sum((1, 3))
    return s / np.maximum(n, 1)


def _figure(width_px: int, height_px: int):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    dpi = 100
    fig = plt.figure(figsize=(max(width_px, 320) / dpi + 1.4, max(height_px, 180) / dpi + 0.6), dpi=dpi)
    return plt, fig


CASE_COLORS = {0: (40, 40, 40), 1: (60, 110, 230), 2: (60, 200, 90), 3: (245, 245, 245)}
CASE_NAMES = {0: "empty", 1: "list", 2: "tree", 3: "mixed"}


def save_classification(case_bits: np.ndarray, size: tuple[int, int], path, title: str = "") -> dict:
    """Per 8x8 group (its WAVE_STATS case_bits): list (blue), tree (green), mixed (white),
    empty (grey), as in the tree paper's figure 3.  Returns the share of groups of each kind."""
    bits = case_bits & 3
    rgb = np.zeros(bits.shape + (3,), np.uint8)
    for k, c in CASE_COLORS.items():
        rgb[bits == k] = c
    w, h = size
    img = np.repeat(np.repeat(rgb, 8, 0), 8, 1)[:h, :w]
    plt, fig = _figure(w, h)
    ax = fig.add_axes([0.02, 0.14, 0.96, 0.74])
    ax.imshow(img, interpolation="nearest")
    ax.set_xticks([]), ax.set_yticks([])
    ax.set_title(title or "hybrid traversal per wave", fontsize=9)
    from matplotlib.patches import Patch
    shares = {CASE_NAMES[k]: float((bits == k).mean()) for k in CASE_COLORS}
    ax.legend(handles=[Patch(color=np.array(CASE_COLORS[k]) / 255, label=f"{CASE_NAMES[k]} {shares[CASE_NAMES[k]]:.0%}")
                       for k in (1, 2, 3, 0)], loc="upper center", bbox_to_anchor=(0.5, -0.01), ncol=4, fontsize=8,
              frameon=False)
    fig.savefig(path)
    plt.close(fig)
    return shares


def ensure_parent(path) -> Path:
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    return p
