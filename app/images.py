"""Images a person looks at: tone-mapped PNG, lights-per-block heat map with a legend,
and the hybrid's list/tree/mixed classification map (tree paper figures 1 and 3)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
from PIL import Image


def tonemap(image: np.ndarray) -> np.ndarray:
    """Linear radiance -> 8-bit sRGB-ish (Reinhard, gamma 2.2)."""
    x = np.nan_to_num(np.maximum(image, 0.0))
    return (np.power(x / (1.0 + x), 1 / 2.2) * 255 + 0.5).astype(np.uint8)


def save_png(image: np.ndarray, path) -> None:
    Image.fromarray(tonemap(image)).save(path)


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


def save_heatmap(evaluated: np.ndarray, path, title: str = "", block: int = 16,
                 vmax: float | None = None) -> None:
    """Lights evaluated per pixel, averaged per 16x16 block, with a colour legend."""
    blocks = block_mean(evaluated.astype(np.float64), block)
    h, w = evaluated.shape
    plt, fig = _figure(w, h)
    ax = fig.add_axes([0.02, 0.08, 0.8, 0.84])
    im = ax.imshow(blocks, cmap="turbo", vmin=0, vmax=vmax or max(blocks.max(), 1),
                   interpolation="nearest", extent=(0, w, h, 0))
    ax.set_xticks([]), ax.set_yticks([])
    ax.set_title(title or f"lights evaluated per pixel ({block}x{block} mean)", fontsize=9)
    cax = fig.add_axes([0.85, 0.08, 0.03, 0.84])
    fig.colorbar(im, cax=cax).set_label("lights / pixel", fontsize=8)
    fig.savefig(path)
    plt.close(fig)


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
