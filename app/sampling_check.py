"""The statistical check of a sampling technique (role "sampler"): its estimate is unbiased.

A sampler's light set at a pixel is not brute's by design (it shades S drawn lights), so the
exactness check holds only its support (every light that affects the pixel can be drawn:
the support pass's count and hash, app/techniques/sample_list).  Its image is held to
brute's statistically: K frames of K seeds (`sample_seed` base .. base + K - 1, the same
frame), and

    frame   the frame's total radiance (luminance summed over its shading pixels) of each
            seed: |mean - brute's| <= FRAME_Z standard errors of that mean (K totals, their
            spread measured; the central limit over a frame's pixels makes them near normal)
    blocks  the same per BLOCK x BLOCK pixel block: at most BLOCK_SHARE of the blocks (and
            one) beyond BLOCK_Z standard errors plus a float tolerance

Blocks, not pixels: a pixel's estimate is heavy-tailed where its cell holds many lights and
few affect it (most draws add nothing, a rare one adds f/p), so K x S draws often never hit
it and leave its mean below brute's with no spread to show it: unbiased, yet far outside a
per-pixel standard error.  The pixels of a block draw independently, so its total sums many
draws and its spread is measured.  A light no draw can reach is the support's failure
(exact, per pixel); tests/app/test_sampling_check.py holds single pixels to brute with
enough draws per pixel on a scene of short lists.

A block can still miss a rare draw in all K seeds (the stress scene's 100,000 lights of 0.3 m:
a cell lists many, a pixel meets about one, so sample-list at S = 4 fails 5 of 240 blocks at
K = 16 and none at 32): a failing check is judged again over ESCALATE x K seeds, those K
included.  A bias stays beyond the standard errors however many seeds; missed rare draws do
not.  A dropped 1/p or a pdf that does not sum to one moves every block by far more than its
standard error and fails both (the tests run such faulty shaders: SAMPLE_FAULT).  The check
cannot prove a zero bias; it bounds the bias it would miss by the standard errors it
measured (reported).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

FRAME_Z = 5.0
BLOCK_Z = 6.0
BLOCK = 16
BLOCK_SHARE = 0.02
REL_TOL = 1e-4              # float32 sums in another order than brute's, tails below it
DEFAULT_SEEDS = 16
ESCALATE = 4                # a failure at K seeds is judged again over ESCALATE x K
LUMA = np.array([0.2126, 0.7152, 0.0722])


@dataclass
class Verdict:
    technique: str
    seeds: int
    frame_z: float                  # (mean total - brute's) / its standard error
    frame_rel: float                # (mean total - brute's) / brute's
    frame_rel_se: float             # the total's standard error / brute's
    blocks: int                     # blocks with a shading pixel
    blocks_off: int                 # blocks beyond BLOCK_Z standard errors (+ tolerance)
    rmse_rel: float                 # one frame's relative RMSE against brute (mean over seeds)

    @property
    def passed(self) -> bool:
        return (abs(self.frame_z) <= FRAME_Z
                and self.blocks_off <= max(1, int(BLOCK_SHARE * self.blocks)))

    def message(self) -> str:
        verdict = "unbiased within its noise" if self.passed else "biased"
        return (f"{self.technique} {verdict} over {self.seeds} seeds: frame total "
                f"{self.frame_rel:+.2%} of brute's (standard error {self.frame_rel_se:.2%}, "
                f"z {self.frame_z:+.1f}, limit {FRAME_Z:g}); {self.blocks_off} of {self.blocks} "
                f"{BLOCK}-pixel blocks beyond {BLOCK_Z:g} standard errors (limit "
                f"{max(1, int(BLOCK_SHARE * self.blocks))}); one frame's relative RMSE "
                f"{self.rmse_rel:.3f}")


def luminance(image: np.ndarray) -> np.ndarray:
    return np.asarray(image, np.float64) @ LUMA


def block_sums(a: np.ndarray, block: int = BLOCK) -> np.ndarray:
    """(..., H, W) -> (..., ceil(H/block), ceil(W/block)): sums over pixel blocks."""
    h, w = a.shape[-2:]
    hb, wb = -(-h // block), -(-w // block)
    pad = np.zeros(a.shape[:-2] + (hb * block, wb * block))
    pad[..., :h, :w] = a
    return pad.reshape(a.shape[:-2] + (hb, block, wb, block)).sum((-3, -1))


def z_scores(samples: np.ndarray, want: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """(mean - want) / standard error over axis 0, 0 where within `tol`, inf where off with
    no spread."""
    k = len(samples)
    gap = samples.mean(0) - want
    se = samples.std(0, ddof=1) / np.sqrt(k)
    gap = np.where(np.abs(gap) <= tol, 0.0, gap)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(gap == 0, 0.0, gap / se)


def judge(technique: str, images: np.ndarray, reference: np.ndarray, shading: np.ndarray) -> Verdict:
    """The verdict on K images (K, H, W, 3) of K seeds against brute's image (H, W, 3), over
    the `shading` pixels (H, W) bool."""
    k = len(images)
    if k < 2:
        raise ValueError("the statistical check needs at least 2 seeds (a spread to measure)")
    lum, ref = luminance(images) * shading, luminance(reference) * shading
    want = float(ref.sum())
    floor = REL_TOL * want / max(int(shading.sum()), 1)          # per pixel
    totals = lum.sum((1, 2))
    frame_z = float(z_scores(totals, np.float64(want), REL_TOL * abs(want)))
    se_total = float(totals.std(ddof=1)) / np.sqrt(k)
    blocks, ref_b = block_sums(lum), block_sums(ref)
    has = block_sums(shading.astype(np.float64)) > 0
    z = z_scores(blocks, ref_b, REL_TOL * np.abs(ref_b) + floor * block_sums(shading.astype(np.float64)))
    scale = max(float(np.sqrt(np.mean(ref[shading] ** 2))), 1e-30) if shading.any() else 1.0
    rmse = float(np.mean(np.sqrt(np.mean((lum[:, shading] - ref[shading]) ** 2, axis=1)))) / scale
    return Verdict(technique, k, frame_z, (float(totals.mean()) - want) / want if want else 0.0,
                   se_total / want if want else 0.0, int(has.sum()),
                   int((np.abs(z[has]) > BLOCK_Z).sum()), rmse)


def seed_images(renderer, technique, opts, frame: int, frames: int, seeds: int,
                defines=None, first: int = 0) -> np.ndarray:
    """(K, H, W, 3) float32: the technique's images of seeds opts.sample_seed + first .. +
    first + K - 1 (their support passes not run: figures off); `defines` as Renderer.render's."""
    base = opts.sample_seed
    out = []
    for k in range(first, first + seeds):
        res = renderer.render(technique, frame, opts.with_(sample_seed=(base + k) % 2**31),
                              frames=frames, figures=False, defines=defines)
        out.append(res.image)
    return np.stack(out)


def check(renderer, technique, opts, reference, frame: int = 0, frames: int = 64,
          seeds: int = DEFAULT_SEEDS, defines=None) -> Verdict:
    """The statistical check of `technique` with `opts` against brute's rendered frame: K
    seeds, and where they fail, ESCALATE x K (the module docstring)."""
    images = seed_images(renderer, technique, opts, frame, frames, seeds, defines)
    verdict = judge(technique.name, images, reference.image, reference.depth > 0)
    if verdict.passed:
        return verdict
    more = seed_images(renderer, technique, opts, frame, frames, (ESCALATE - 1) * seeds, defines,
                       first=seeds)
    return judge(technique.name, np.concatenate([images, more]), reference.image,
                 reference.depth > 0)
