"""Shared fixtures: one EGL context for the whole session (objects of two contexts
interfere), a seeded rng.  No GL here for cpu_prep tests: they never request `gl`.

Parallel runs (pytest-xdist; scripts/test.sh passes `-n auto --dist loadgroup`): every worker
is its own process, so it has its own EGL context (app/pipeline/gl.py: one a process) and
its own session fixtures.  What the workers would share is made safe, or made theirs, here:

- numba's on-disk cache stays shared (cpu_prep's folder, keyed by the package's source), so
  a kernel one worker compiled is loaded by the other and by every later run, but its index
  is made safe for them: numba.core.caching.IndexDataCacheFile.save reads the index, picks
  the first free data-file number and writes both back without a lock, so two processes
  saving new signatures of one function at once can each pick `.1`, and the index may then
  name the other's machine code.  Here every test process holds a lock on that index while
  it saves (_lock_numba_cache_saves).  The CLI subprocesses some tests start (capture,
  bench, window) do not take it: a collision needs one of them and another process to save
  different signatures of one function within the same millisecond; two saves of one
  signature are harmless.  (A folder per worker was tried: each then compiles what the
  other already had, minutes of a "warm" run.)
- the window's start-up probe memory (app/window/probe.py): LAB_CACHE_DIR, a temporary
  folder per process (the user's own setting too), so no test reads or writes the user's
  ~/.cache and two workers never write one file.

Tests of a module whose module-scoped fixture is expensive (the concurrent CLI runs of
test_bad_input and test_long_run, the bench sweep, a rendered frame) share one worker, so
that fixture runs once (GROUPED below, scheduled as groups under --dist loadgroup); so do
the tests of one builtin scene that share its reference frame (SHARED_REFERENCE).
"""
import os
import re
import shutil
import tempfile

import numpy as np
import pytest
from hypothesis import settings

# No per-example deadline (first calls compile numba kernels and shaders); CI replays the
# same examples every run (derandomize) so a red build is reproducible; a local run draws
# new ones, and a failure prints the @reproduce_failure blob that replays it (print_blob).
settings.register_profile("lab", deadline=None, print_blob=True)
settings.register_profile("ci", deadline=None, derandomize=True, print_blob=True)
settings.load_profile("ci" if os.environ.get("CI") else "lab")


def _lock_numba_cache_saves() -> None:
    """Serialize numba's cache-index updates across processes (see the module docstring):
    save() re-reads the index under the lock, so each process sees the others' entries."""
    import fcntl
    from numba.core import caching
    cls = caching.IndexDataCacheFile
    if getattr(cls.save, "_lab_locked", False):
        return
    unlocked = cls.save

    def save(self, key, data):
        os.makedirs(self._cache_path, exist_ok=True)
        with open(self._index_path + ".lock", "a") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)        # released when the file closes
            return unlocked(self, key, data)

    save._lab_locked = True
    cls.save = save


# Modules whose tests must run on one worker: their module-scoped fixture costs seconds to
# tens of seconds (the CLI processes of every bad-input case; two capture processes per
# technique; a whole bench sweep; a hangar or city frame), and under plain load
# distribution each worker holding one of their tests would run it again.
GROUPED = ("tests/app/test_bad_input.py", "tests/app/test_long_run.py",
           "tests/app/bench/test_bench_sweep.py", "tests/app/techniques/test_zbin_technique.py",
           "tests/app/window/test_present.py")

# Tests that share one reference frame (tests.helpers.builtin_reference: rendered once per
# process) run on one worker: node id pattern -> the scope's name ({0}: the pattern's group).
SHARED_REFERENCE = (
    (r"tests/app/techniques/test_exactness\.py::test_builtin_scenes_are_exact\[([\w-]+)-uniform\]$",
     "reference {0}"),
    (r"tests/app/techniques/test_tree_options\.py::test_options_exact_on_every_scene\[([\w-]+)\]$",
     "reference {0}"),
    (r"tests/app/techniques/test_exactness\.py::test_options_keep_exactness\[", "reference arena 4096"),
)


def shared_reference_scope(nodeid: str) -> str | None:
    for pattern, scope in SHARED_REFERENCE:
        m = re.match(pattern, nodeid)
        if m:
            return scope.format(*m.groups())
    return None


MAX_WORKERS = 8     # each worker holds a GL context, its shaders and numba kernels (0.3-0.8 GB)


def pytest_xdist_auto_num_workers(config):
    """`-n auto`: one worker a core (at most MAX_WORKERS; LAB_TEST_JOBS overrides), and none
    when the command names only single tests (`path::test`): a worker's start-up (imports,
    its own GL context and shaders) would cost more than it saves."""
    if config.args and all("::" in a for a in config.args):
        return 0
    if os.environ.get("LAB_TEST_JOBS"):
        return max(0, int(os.environ["LAB_TEST_JOBS"]))
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return min(cores or 1, MAX_WORKERS)


def pytest_configure(config):
    _lock_numba_cache_saves()
    # every process its own (a worker would otherwise inherit the controller's folder)
    config._lab_cache_before = os.environ.get("LAB_CACHE_DIR")
    config._lab_cache_dir = tempfile.mkdtemp(prefix="lab-test-cache-")
    os.environ["LAB_CACHE_DIR"] = config._lab_cache_dir


def pytest_unconfigure(config):
    d = getattr(config, "_lab_cache_dir", None)
    if d:
        shutil.rmtree(d, ignore_errors=True)
        if config._lab_cache_before is None:
            os.environ.pop("LAB_CACHE_DIR", None)
        else:
            os.environ["LAB_CACHE_DIR"] = config._lab_cache_before


@pytest.hookimpl(tryfirst=True)     # before xdist's own scheduler for --dist loadgroup
def pytest_xdist_make_scheduler(config, log):
    """--dist loadgroup with the GROUPED modules as groups.  xdist 3.8 groups by an
    `xdist_group` mark through the item's `_nodeid`, which pytest 9 no longer reads (node ids
    come from `_id`), so its marks group nothing here; the scheduler is told the groups by
    path instead (any other test is its own unit, as with loadgroup)."""
    if config.getvalue("dist") != "loadgroup":
        return None
    from xdist.scheduler import LoadGroupScheduling

    class Grouped(LoadGroupScheduling):
        def _split_scope(self, nodeid: str) -> str:
            path = nodeid.split("::", 1)[0]
            if path in GROUPED:
                return path
            return shared_reference_scope(nodeid) or super()._split_scope(nodeid)

    return Grouped(config, log)


@pytest.fixture(scope="session")
def gl():
    from app.pipeline import gl as glmod
    from app.errors import UserError
    try:
        return glmod.context()
    except UserError as exc:   # a missing GL is a failure, not a skip: CI must have it
        pytest.fail(f"no GL context: {exc}")


@pytest.fixture
def rng():
    return np.random.default_rng(12345)
