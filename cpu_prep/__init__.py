"""CPU stage of the frame: numpy in, numpy GPU-layout arrays out.  No OpenGL here.

The kernels are numba.  The pack, the fill of the binning, listing 2 and the tree build
cut their work into chunks that threads claim (cpu_prep.share: a helper that a busy core
does not schedule claims nothing and stalls nothing), and so do the cull and the boxes' count.
The CPU stage runs on DEFAULT_THREADS (two, where the machine has two cores) unless
LAB_CPU_THREADS says otherwise; the benchmark measures one thread unless told (`--threads`),
as the tree paper's figure 4 does (docs/cpu_stage.md measures both).  Both give the same bits.
"""
from contextlib import contextmanager
import hashlib
import os
from pathlib import Path

import numba


# The folders of the project's numba kernels: this package's and the cost model's wave replay
# (whose kernels inline the light tests and constants of their sibling modules).
_KERNEL_DIRS = (Path(__file__).parent, Path(__file__).parents[1] / "app" / "model" / "waves")


def _cache_dir() -> Path:
    """numba's on-disk cache, keyed by the source of every kernel folder: numba re-checks
    only a kernel's own file, not the limits, inline bounds and light tests it compiled in."""
    h = hashlib.sha1()
    for p in sorted(q for d in _KERNEL_DIRS for q in d.glob("*.py")):
        h.update(p.name.encode() + p.read_bytes())
    base = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return base / "many-light-lab" / "numba" / h.hexdigest()[:16]


if not os.environ.get("NUMBA_CACHE_DIR"):
    numba.config.CACHE_DIR = str(_cache_dir())
# two threads: 0.65-0.87x one thread's time at 65,536 lights with the other core idle, and no
# more than one thread's with it busy (docs/cpu_stage.md, "Threads")
DEFAULT_THREADS = 2
numba.set_num_threads(max(1, min(int(os.environ.get("LAB_CPU_THREADS", DEFAULT_THREADS)),
                                 numba.config.NUMBA_NUM_THREADS)))


def parallel() -> bool:
    """Whether the CPU stage shares its steps among threads (LAB_CPU_THREADS /
    set_num_threads > 1, cpu_prep.share); with one thread each step is one chunk."""
    return numba.get_num_threads() > 1


def threads() -> int:
    """The threads the CPU stage runs on now (DEFAULT_THREADS, LAB_CPU_THREADS, or
    set_num_threads)."""
    return int(numba.get_num_threads())


@contextmanager
def using_threads(n: int):
    """The CPU stage on n threads (at most numba's) inside the block, the count before it
    restored after."""
    before = numba.get_num_threads()
    numba.set_num_threads(max(1, min(int(n), numba.config.NUMBA_NUM_THREADS)))
    try:
        yield threads()
    finally:
        numba.set_num_threads(before)
