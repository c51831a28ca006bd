"""cpu_prep.share: every chunk done once by some thread, and a helper that is not running
(a busy core) neither stalls the caller nor does any work late."""
import threading

import numba
import numpy as np
import pytest

from cpu_prep import share
from cpu_prep.intrinsics import fetch_add
from tests.helpers import threads_or_skip, with_threads


@numba.njit(nogil=True)
def count_chunks(claim, chunks, hits, spin):
    k = fetch_add(claim, 0, 1)
    while k < chunks:
        acc = 0
        for j in range(spin):            # some work, so that threads overlap
            acc = (acc * 31 + j) % 1000003
        fetch_add(hits, k, 1 if acc >= 0 else 2)
        fetch_add(claim, 1, 1)
        k = fetch_add(claim, 0, 1)


@pytest.mark.parametrize("threads,chunks", [(1, 1), (1, 9), (2, 1), (2, 64), (2, 0)])
def test_every_chunk_once(threads, chunks):
    for _ in range(20):
        hits = np.zeros(max(chunks, 1), np.int64)
        with_threads(threads, lambda: share.run(count_chunks, chunks, hits, 20000))
        assert np.all(hits[:chunks] == 1) and hits.sum() == chunks


def test_a_helper_held_busy_does_not_stall_the_caller():
    threads_or_skip(2)
    release = threading.Event()
    started = threading.Event()

    def busy():                           # stands in for a helper that gets no time slice
        started.set()
        release.wait()

    q = share._helpers(1)[0]
    task = share._Task(busy, ())
    q.put(task)
    assert started.wait(10)
    hits = np.zeros(32, np.int64)
    with_threads(2, lambda: share.run(count_chunks, 32, hits, 1000))
    assert np.all(hits == 1)              # the caller did every chunk, without the helper
    release.set()
    assert task.done.wait(10)
    late = share._Task(lambda: None, ())  # the helper has run the stale call by now
    q.put(late)
    assert late.done.wait(10)
    assert np.all(hits == 1)              # ... and it claimed nothing
