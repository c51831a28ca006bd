"""A one-page first look at a folder of captures (scripts/main.sh writes it within about a
minute, before the benchmark report):

    python -m app.summary out/capture [--out out/summary]

reads every capture dump in the folder (`--dump`, docs/contracts.md "Contract: capture and dump") of one
scene and frame, and writes

    summary.png  the reference's shaded image, then every technique's heat map of lights
                 evaluated per pixel, all on one scale with its colour bar (the lab's one heat
                 definition, app.images: what capture's --heatmap and the window's heat view
                 show), each titled with its mean and its culling waste; the exactness line
                 on top
    summary.md   the same page in words: the exactness line, the picture, a table per
                 technique (lights evaluated and exact per pixel, waste, CPU and GPU ms,
                 culling bytes, pixels that differ from the reference) and the captures

The exactness line counts, for each technique, the pixels whose contrib_count or
contrib_hash differs from the reference's (`brute`): the lab's guarantee is 0 everywhere.
The figures are one frame of llvmpipe, for a look; the benchmark report measures.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

from .errors import UserError


def load(folder: Path) -> dict:
    """{technique: dump} of the folder's dumps, in the registry's order; all of one scene,
    frame and size, with the reference among them."""
    from .dump import read_dump
    from .techniques import REGISTRY, with_role
    paths = sorted(Path(folder).glob("*.npz"))
    if not paths:
        raise UserError(f"{folder}: no capture dumps (*.npz) in it; make them with "
                        f"python -m app.capture ... --dump {folder}/NAME.npz")
    dumps = {}
    for p in paths:
        try:
            d = read_dump(p)
        except (OSError, KeyError, ValueError) as exc:
            raise UserError(f"{p}: not a capture dump ({exc})") from None
        d["path"] = p
        name = d["meta"].get("technique", p.stem)
        if name in dumps:
            raise UserError(f"{p}: a second dump of {name} (also {dumps[name]['path'].name}); "
                            "one a technique")
        dumps[name] = d
    first = next(iter(dumps.values()))
    key = lambda d: (d["meta"].get("scene"), d["meta"].get("lights"), d["meta"].get("seed"),
                     d["meta"].get("frame"), tuple(d["contrib_count"].shape))
    for name, d in dumps.items():
        if key(d) != key(first):
            raise UserError(f"{d['path']}: another frame ({key(d)}) than {first['path'].name} "
                            f"({key(first)}); one scene, frame and size a folder")
    ref = with_role("reference").name
    if ref not in dumps:
        raise UserError(f"{folder}: no dump of the reference technique {ref}: the exactness "
                        "line compares every technique with it")
    order = [n for n in REGISTRY if n in dumps] + sorted(n for n in dumps if n not in REGISTRY)
    return {n: dumps[n] for n in order}


def figures(dumps: dict) -> dict:
    """Per technique: evaluated and exact lights per covered pixel, waste, pixels that differ
    from the reference (count or hash), CPU and GPU ms, culling bytes."""
    from .techniques import with_role
    ref = dumps[with_role("reference").name]
    out = {}
    for name, d in dumps.items():
        covered = d["depth"] > 0
        ev = float(d["evaluated"][covered].mean()) if covered.any() else 0.0
        ex = float(d["contrib_count"][covered].mean()) if covered.any() else 0.0
        differ = (d["contrib_count"] != ref["contrib_count"]) | (d["contrib_hash"] != ref["contrib_hash"])
        m = d["meta"]
        out[name] = {
            "evaluated": ev, "exact": ex, "waste": ev / ex if ex > 0 else math.nan,
            "differ": int(differ.sum()), "pixels": int(differ.size),
            "cpu_ms": float(sum(m.get("cpu_ms", {}).values())),
            "gpu_ms": float(sum(m.get("gpu_ms", {}).values())),
            "bytes": int(sum(m.get("bytes", {}).values())),
        }
    return out


def exactness_line(figs: dict, reference: str, short: bool = False) -> str:
    """The exactness line; `short`: without what a sampler's lights are (the picture says it
    in its footnote)."""
    others = {n: f for n, f in figs.items() if n != reference}
    pixels = next(iter(figs.values()))["pixels"]
    bad = {n: f["differ"] for n, f in others.items() if f["differ"]}
    if not bad:
        from .techniques import REGISTRY
        samplers = [n for n in others if n in REGISTRY and REGISTRY[n].role == "sampler"]
        support = _sampler_note(samplers, reference) if samplers and not short else ""
        return (f"Exact: all {len(others)} techniques give {reference}'s lights (contrib_count and "
                f"contrib_hash) at every one of {pixels:,} pixels: 0 pixels differ{support}.")
    return (f"NOT exact: {len(bad)} of {len(others)} techniques differ from {reference} "
            f"(contrib_count or contrib_hash) at some of {pixels:,} pixels: "
            + ", ".join(f"{n} {k:,} px" for n, k in bad.items())
            + f"; python -m app.capture ... --check DIR names the first differing pixel.")


def _sampler_note(samplers, reference: str) -> str:
    return (f" ({', '.join(samplers)}: the lights their draws can reach; their images are "
            f"unbiased estimates, held to {reference}'s by capture --check's statistical check)")


def _title(dumps: dict) -> str:
    m = next(iter(dumps.values()))["meta"]
    w, h = m.get("resolution", next(iter(dumps.values()))["depth"].shape[::-1])
    lights = f"{m['lights']:,} lights" if "lights" in m else "its lights"
    return f"{m.get('scene', 'scene')}, {lights}, {w}x{h}, frame {m.get('frame', 0)}"


def num(v: float) -> str:
    """3 significant digits, thousands as whole numbers (3,880 rather than 3.88e+03)."""
    return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.3g}"


def draw(dumps: dict, figs: dict, reference: str, path: Path) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.cm import ScalarMappable
    from . import images

    ref = dumps[reference]
    covered = ref["depth"] > 0
    vmax = max(max(images.heat_max(d["evaluated"], d["depth"] > 0) for d in dumps.values()), 1.0)
    panels = [None] + list(dumps)           # None: the shaded frame
    cols = 4 if len(panels) > 9 else 3
    rows = math.ceil(len(panels) / cols)
    h, w = covered.shape
    pw = 3.3
    ph = pw * h / w + 0.5
    fig, axes = plt.subplots(rows, cols, squeeze=False, dpi=100,
                             figsize=(cols * pw + 1.4, rows * ph + 1.5))
    for ax in axes.ravel():
        ax.axis("off")
    for ax, name in zip(axes.ravel(), panels):
        if name is None:
            png = ref["path"].with_suffix(".png")
            if png.is_file():
                from PIL import Image
                shown = np.asarray(Image.open(png).convert("RGB"))
            else:
                shown = images.display(ref["image"], exposure=images.auto_exposure(ref["image"], covered))
            ax.imshow(shown, interpolation="nearest")
            ax.set_title("the frame, shaded\n(what every technique must light alike)", fontsize=9)
            continue
        d, f = dumps[name], figs[name]
        ax.imshow(images.heat_rgb(d["evaluated"], d["depth"] > 0, vmax), interpolation="nearest")
        waste = "" if math.isnan(f["waste"]) else f"{num(f['waste'])}x what lights it; "
        if name == reference:
            verdict, colour = "the reference", "black"
        elif f["differ"]:
            verdict, colour = f"{f['differ']:,} px DIFFER", "red"
        else:
            verdict, colour = f"= {reference}", "black"
        ax.set_title(f"{name}: {num(f['evaluated'])} lights / px\n{waste}{verdict}", fontsize=9,
                     color=colour)
    fig.subplots_adjust(left=0.01, right=0.885, bottom=0.06, top=0.86, wspace=0.04, hspace=0.32)
    cax = fig.add_axes([0.905, 0.14, 0.014, 0.64])
    bar = fig.colorbar(ScalarMappable(norm=images.heat_norm(vmax), cmap=images.heat_cmap()), cax=cax)
    ticks = images.heat_ticks(vmax)
    bar.set_ticks(ticks, labels=[images.fmt_tick(v) for v in ticks])
    bar.set_label("lights evaluated per pixel (log scale)", fontsize=9)
    line = exactness_line(figs, reference, short=True)
    from .techniques import REGISTRY
    samplers = [n for n in figs if n in REGISTRY and REGISTRY[n].role == "sampler"]
    fig.suptitle(f"Lights each technique evaluates per pixel: {_title(dumps)}", fontsize=13, y=0.985)
    fig.text(0.45, 0.935, line, ha="center", va="top", fontsize=10, weight="bold",
             color="darkgreen" if line.startswith("Exact") else "red")
    fig.text(0.01, 0.012, "Colour: lights the shading loop evaluates at the pixel (one scale for all); "
             "black: sky; darkest grey: none evaluated.  'Nx what lights it': evaluated / lights "
             "that affect the pixel (culling waste; 1 is perfect).\n"
             f"'= {reference}': contrib_count and contrib_hash equal {reference}'s at every pixel"
             + (_sampler_note(samplers, reference) if samplers else "") + ".\n"
             "One frame on this machine; the quick benchmark report measures costs.",
             fontsize=8, color="dimgray", va="bottom")
    fig.savefig(path)
    plt.close(fig)


def write_markdown(dumps: dict, figs: dict, reference: str, png: Path, path: Path) -> None:
    import os
    rel = lambda p: os.path.relpath(p, path.parent)
    lines = [f"# First look: {_title(dumps)}", "", f"**{exactness_line(figs, reference)}**", "",
             f"![lights evaluated per pixel, every technique]({rel(png)})", "",
             "| technique | evaluated / px | exact / px | waste | CPU ms | GPU ms | culling bytes | "
             "pixels differing from " + reference + " | capture |",
             "|---|---|---|---|---|---|---|---|---|"]
    for name, f in figs.items():
        d = dumps[name]
        shot = d["path"].with_suffix(".png")
        heat = d["path"].with_name(d["path"].stem + "-heat.png")
        links = " ".join(f"[{label}]({rel(p)})" for label, p in (("image", shot), ("heat", heat))
                         if p.is_file()) or rel(d["path"])
        waste = "" if math.isnan(f["waste"]) else f"{num(f['waste'])}x"
        lines.append(f"| {name} | {num(f['evaluated'])} | {num(f['exact'])} | {waste} | "
                     f"{f['cpu_ms']:.2f} | {f['gpu_ms']:.2f} | {f['bytes']:,} | "
                     f"{'-' if name == reference else format(f['differ'], ',')} | {links} |")
    lines += ["", "Per pixel means over the pixels with geometry. waste: lights evaluated per light "
              "that affects the pixel (1 is perfect culling). CPU and GPU ms: one frame of each "
              "capture, as it happened (main.sh runs them one a core, on llvmpipe, a software "
              "rasterizer, where only ratios mean anything); the quick benchmark report measures "
              "them properly.", ""]
    path.write_text("\n".join(lines))


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="python -m app.summary", description=__doc__.splitlines()[0])
    p.add_argument("folder", help="a folder of capture dumps (*.npz) of one frame, the reference's among them")
    p.add_argument("--out", help="output path without suffix (default: FOLDER/../summary): "
                   "writes OUT.png and OUT.md")
    from .cli import Parser
    p.__class__ = Parser        # one-line argument errors, as the other tools
    args = p.parse_args(argv)
    folder = Path(args.folder)
    if not folder.is_dir():
        raise UserError(f"{folder}: no such folder")
    from .techniques import with_role
    reference = with_role("reference").name
    dumps = load(folder)
    figs = figures(dumps)
    base = Path(args.out) if args.out else folder.parent / "summary"
    base.parent.mkdir(parents=True, exist_ok=True)
    png, md = base.with_suffix(".png"), base.with_suffix(".md")
    draw(dumps, figs, reference, png)
    write_markdown(dumps, figs, reference, png, md)
    print(exactness_line(figs, reference))
    print(f"summary: {md} ({png})")
    if any(f["differ"] for n, f in figs.items() if n != reference):
        raise SystemExit(1)


if __name__ == "__main__":
    from .cli import run_main
    run_main(lambda: main(sys.argv[1:]))
