"""CPU stage of the frame: numpy in, numpy GPU-layout arrays out.  No OpenGL here.

The kernels are numba; the tree build, binning and packing loops are written for numba's
prange, but run on ONE thread unless LAB_CPU_THREADS says otherwise: on a 2-core machine
whose other core is busy (the GPU driver, llvmpipe, a test runner) a parallel region waits
for a time slice and costs ~10 ms, far more than it saves.  The tree paper's figure 4 is
single-threaded too.
"""
import os

import numba

numba.set_num_threads(max(1, min(int(os.environ.get("LAB_CPU_THREADS", "1")), numba.config.NUMBA_NUM_THREADS)))
