"""Running the window as a user does (a subprocess, headless or under Xvfb) and reading what it
prints and saves: shared by the window's test modules."""
from __future__ import annotations

import json
import os
from pathlib import Path
import subprocess
import sys

import numpy as np
from PIL import Image

ROOT = Path(__file__).resolve().parents[3]
SMALL = ["--scene", "city", "--lights", "32", "--size", "160x90"]
LIT = ["--scene", "city", "--size", "160x90"]        # the default 4096 lights: a lit image


def run(args, prefix=(), timeout=180, env=None):
    env = dict(os.environ, **(env or {}))
    env.pop("MODERNGL_WINDOW", None)       # it would override --window
    proc = subprocess.run([*prefix, sys.executable, "-m", *args], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=timeout)
    return proc


def run_window(args, prefix=(), headless=True, env=None):
    cmd = ["app.window"] + (["--window", "headless"] if headless else []) + list(args)
    proc = run(cmd, prefix, env=env)
    assert proc.returncode == 0, f"exit {proc.returncode}: {proc.stderr[-2000:]}"
    lines = [json.loads(l) for l in proc.stdout.splitlines() if l.startswith("{")]
    frames = [l for l in lines if "frame" in l]
    summary = [l for l in lines if l.get("exit") == "ok"]
    assert len(summary) == 1, proc.stdout[-2000:]
    return frames, summary[0], proc


def load_rgb(path) -> np.ndarray:
    return np.asarray(Image.open(path).convert("RGB")).astype(np.int16)
