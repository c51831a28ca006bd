"""Work sharing for the CPU stage's threaded steps: threads that a busy core does not stall.

A numba prange region (the OpenMP layer) splits its loop among all its threads and ends at
a barrier: when the other core is busy, the calling thread waits for the second thread's
time slice, at every region (21-32 ms for a hybrid frame that takes 8 on one thread,
docs/cpu_stage.md).  Here a step is cut into chunks that threads *claim*:

    run(kernel, chunks, *args)    kernel(claim, chunks, *args), a plain nogil kernel, loops
                                  k = fetch_add(claim, 0, 1) while k < chunks, does chunk
                                  k, then fetch_add(claim, 1, 1) (chunks done); a kernel
                                  that needs a slot of its own a thread (a partial sum)
                                  takes fetch_add(claim, 2, 1): 0 .. threads - 1

The calling thread runs the kernel itself and hands the same call to the helper threads
(plain Python threads; the kernels release the GIL).  A helper that is not scheduled claims
nothing, so the caller does every chunk and returns without waiting for it; the caller
waits only for chunks a helper has claimed and not finished.  A late helper finds every
chunk claimed and returns at once.  Each chunk is written by the thread that claimed it, so
the bits do not depend on which thread did what.  The helper count is numba's thread count
less one (LAB_CPU_THREADS, cpu_prep.parallel()).
"""
from __future__ import annotations

import queue
import threading

import numba
import numpy as np

_POLL_S = 5e-5          # how often the caller looks at the chunks done while it waits
_queues: list[queue.SimpleQueue] = []
_lock = threading.Lock()


class _Task:
    __slots__ = ("kernel", "args", "done", "error")

    def __init__(self, kernel, args):
        self.kernel, self.args = kernel, args
        self.done = threading.Event()
        self.error = None


def _helper(q: queue.SimpleQueue) -> None:
    while True:
        task = q.get()
        try:
            task.kernel(*task.args)
        except BaseException as e:          # re-raised by the caller, if it waits for it
            task.error = e
        finally:
            task.done.set()


def _helpers(n: int) -> list[queue.SimpleQueue]:
    with _lock:
        while len(_queues) < n:
            q = queue.SimpleQueue()
            threading.Thread(target=_helper, args=(q,), daemon=True,
                             name=f"cpu_prep-share-{len(_queues)}").start()
            _queues.append(q)
        return _queues[:n]


def run(kernel, chunks: int, *args) -> None:
    """kernel(claim, chunks, *args) on this thread and on numba.get_num_threads() - 1
    helpers (at most chunks - 1); returns when every chunk is done."""
    claim = np.zeros(3, np.int64)           # [next chunk, chunks done, threads arrived]
    helpers = min(numba.get_num_threads(), chunks) - 1
    tasks = [_Task(kernel, (claim, chunks) + args) for _ in range(max(helpers, 0))]
    for q, task in zip(_helpers(len(tasks)), tasks):
        q.put(task)
    kernel(claim, chunks, *args)
    while claim[1] < chunks:                # a helper is inside a chunk it claimed
        for task in tasks:                  # (not waiting for helpers that claimed none)
            if task.error is not None:
                raise task.error
            if not task.done.is_set():
                task.done.wait(_POLL_S)
