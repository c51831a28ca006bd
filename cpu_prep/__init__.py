"""CPU stage of the frame: numpy in, numpy GPU-layout arrays out.  No OpenGL here.

The kernels are numba.  The pack, the fill of the binning, listing 2 and the tree build
each have a serial kernel and a prange one; the CPU stage runs on ONE thread, with the
serial kernels, unless LAB_CPU_THREADS (or `bench cpu --threads`) says otherwise: on a
2-core machine whose other core is busy (the GPU driver, llvmpipe, a test runner) a
parallel region waits for a time slice and costs more than it saves (docs/cpu_stage.md
measures it).  The tree paper's figure 4 is single-threaded too.  Both give the same bits.
"""
import hashlib
import os
from pathlib import Path

import numba


def _cache_dir() -> Path:
    """numba's on-disk cache, keyed by the source of this whole package: numba re-checks
    only a kernel's own file, not the limits and inline bounds it compiled in."""
    h = hashlib.sha1()
    for p in sorted(Path(__file__).parent.glob("*.py")):
        h.update(p.name.encode() + p.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "many-light-lab" / "numba" / h.hexdigest()[:16]


if not os.environ.get("NUMBA_CACHE_DIR"):
    numba.config.CACHE_DIR = str(_cache_dir())
numba.set_num_threads(max(1, min(int(os.environ.get("LAB_CPU_THREADS", "1")), numba.config.NUMBA_NUM_THREADS)))


def parallel() -> bool:
    """Whether the CPU stage runs its parallel kernels (LAB_CPU_THREADS / set_num_threads > 1).
    With one thread every step calls a plain serial kernel: a parallel=True kernel run on
    one thread still pays numba's parallel-region entry and compiles its loop as an
    outlined gufunc."""
    return numba.get_num_threads() > 1
