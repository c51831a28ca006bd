"""What a run was measured on (run.json): CPU model, cores, Python, system, GL renderer."""
from __future__ import annotations

import os
from pathlib import Path
import platform

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
    return info
