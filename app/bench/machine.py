"""What a run was measured on (run.json): CPU model, cores, Python, system, GL renderer, and
on an NVIDIA GPU its clocks as nvidia-smi reads them when the run ends."""
from __future__ import annotations

import os
from pathlib import Path
import platform
import shutil
import subprocess

from ..errors import UserError


def machine_info() -> dict:
    model = platform.processor() or platform.machine()
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    info = {"cpu": model, "cores": os.cpu_count(), "python": platform.python_version(),
            "system": f"{platform.system()} {platform.release()}"}
    try:
        from ..pipeline import gl
        lim = gl.limits()
        info.update(gl_renderer=lim.renderer, gl_version=lim.version, software=lim.software)
    except UserError as exc:
        info.update(gl_renderer=f"unavailable ({exc})", gl_version="", software=True)
    clocks = gpu_clocks()
    if clocks:
        info["gpu_clocks"] = clocks
    return info


def gpu_clocks() -> str | None:
    """nvidia-smi's SM clock, its maximum and the performance state (a GPU timed below its
    boost clock reads slow), None where there is no nvidia-smi or it fails."""
    exe = shutil.which("nvidia-smi")
    if not exe:
        return None
    try:
        out = subprocess.run([exe, "--query-gpu=clocks.sm,clocks.max.sm,pstate",
                              "--format=csv,noheader"], capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    parts = [x.strip() for x in (out.splitlines() or [""])[0].split(",")]
    return f"SM {parts[0]} of {parts[1]}, {parts[2]}" if len(parts) == 3 and parts[0] else None
