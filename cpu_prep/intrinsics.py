"""What numba does not offer the CPU stage's kernels: a software prefetch for the
pack's gather, float32 bit access (next float up/down without a libm call), streaming
stores, and an atomic add (the work sharing's chunk claim, cpu_prep.share).

Prefetch.

The pack walks the visible lights in depth order and so reads the scene's light records
(84 bytes, 5.5 MB at 65,536 lights) in random order.  Its loop body is a few hundred
instructions (the screen bounds' square roots and divisions), so the out-of-order core
holds only one record's cache miss in flight at a time and waits the whole memory latency
for each: 1.5-6 ms at 65,536 lights on the 2-core VM, depending on what the other core
evicted.  `prefetch(array, i)` asks for every cache line of element i some iterations
ahead (PREFETCH_AHEAD), which hides that latency; it never faults and changes no value.
"""
from __future__ import annotations

import platform
import re
import sys

import numba
import numpy as np

# What follows generates LLVM IR through numba's internals (numba.core.cgutils, the array
# model's make_array / get_item_pointer, get_or_insert_function, the data model's sizes) and
# llvmlite's IR builder, with its pointer spelling: none of it is numba's public API, and it
# changes between minor versions.  These are the minor versions it is tested on
# (pyproject.toml bounds numba to them; constraints.txt pins the tested set); another is
# refused here, before any kernel compiles, in one line.
NUMBA_TESTED = ((0, 68),)


class NumbaVersionError(ImportError):
    """The installed numba is not one of NUMBA_TESTED."""


def check_numba(version: str) -> None:
    minor = tuple(int(v) for v in re.findall(r"\d+", version)[:2])
    if minor not in NUMBA_TESTED:
        tested = " or ".join(f"{a}.{b}.x" for a, b in NUMBA_TESTED)
        raise NumbaVersionError(
            f"numba {version} is installed, but the CPU stage (cpu_prep/intrinsics.py, which "
            f"uses numba's internals) is tested on numba {tested} only; install the tested "
            f"versions: bash scripts/setup.sh, or pip install -c constraints.txt -e '.[test]'")


def _one_line(exc_type, exc, tb, _default=sys.excepthook):
    """A wrong numba reaches the user as one line (the CLIs turn only their own errors into
    one), not as a traceback through the import chain."""
    if issubclass(exc_type, NumbaVersionError):
        print(f"error: {exc}", file=sys.stderr)
    else:
        _default(exc_type, exc, tb)


try:
    check_numba(numba.__version__)
except NumbaVersionError:
    sys.excepthook = _one_line
    raise

from llvmlite import ir  # noqa: E402  (after the check: numba's internals)
from numba import types  # noqa: E402
from numba.core import cgutils  # noqa: E402
from numba.extending import intrinsic  # noqa: E402

PREFETCH_AHEAD = 16        # iterations ahead: ~8 x 60 ns of work covers a memory latency
CACHE_LINE = 64


def _prefetch_codegen(rw):
    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1]],
                                       wraparound=False, boundscheck=False)
        i8 = ir.IntType(8)
        i32 = ir.IntType(32)
        base = builder.bitcast(ptr, i8.as_pointer())
        fnty = ir.FunctionType(ir.VoidType(), [base.type, i32, i32, i32])
        name = "llvm.prefetch.p0" if str(base.type) == "ptr" else "llvm.prefetch.p0i8"
        fn = cgutils.get_or_insert_function(builder.module, fnty, name)
        size = context.get_abi_sizeof(context.get_data_type(aryty.dtype))
        offsets = list(range(0, size, CACHE_LINE)) + ([size - 1] if size > 1 else [])
        for off in offsets:
            p = builder.gep(base, [ir.Constant(ir.IntType(64), off)])
            builder.call(fn, [p, i32(rw), i32(3), i32(1)])     # read/write, keep, data
        return context.get_dummy_value()
    return codegen


@intrinsic
def prefetch(typingctx, arr, idx):
    """Prefetch for reading (keep in all cache levels) every cache line of arr[idx], a 1D
    array."""
    if not isinstance(arr, types.Array) or arr.ndim != 1 or not isinstance(idx, types.Integer):
        return None
    return types.void(arr, idx), _prefetch_codegen(0)


@intrinsic
def f32_to_bits(typingctx, x):
    """The IEEE bits of a float32, as uint32."""
    if not isinstance(x, types.Float) or x.bitwidth != 32:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.IntType(32))

    return types.uint32(x), codegen


@intrinsic
def bits_to_f32(typingctx, u):
    """The float32 whose IEEE bits are the low 32 bits of the integer u."""
    if not isinstance(u, types.Integer) or u.bitwidth < 32:
        return None

    def codegen(context, builder, signature, args):
        v = args[0]
        if signature.args[0].bitwidth > 32:
            v = builder.trunc(v, ir.IntType(32))
        return builder.bitcast(v, ir.FloatType())

    return types.float32(u), codegen


@intrinsic
def bits_to_f64(typingctx, u):
    """The float64 whose IEEE bits are the 64-bit integer u."""
    if not isinstance(u, types.Integer) or u.bitwidth != 64:
        return None

    def codegen(context, builder, signature, args):
        return builder.bitcast(args[0], ir.DoubleType())

    return types.float64(u), codegen


@numba.njit(inline="always")
def next_up_f32(f):
    """np.nextafter(f, +inf) for a float32 f, bit for bit (NaN stays NaN, +inf stays +inf,
    either zero goes to the smallest positive subnormal), without numpy's libm call (~2 ns,
    three a light in the pack)."""
    if f != f or f == np.float32(np.inf):
        return f
    if f == np.float32(0.0):
        return bits_to_f32(np.uint32(1))
    u = f32_to_bits(f)
    return bits_to_f32(u + np.uint32(1) if f > np.float32(0.0) else u - np.uint32(1))


@numba.njit(inline="always")
def next_down_f32(f):
    """np.nextafter(f, -inf) for a float32 f, bit for bit."""
    if f != f or f == np.float32(-np.inf):
        return f
    if f == np.float32(0.0):
        return bits_to_f32(np.uint32(0x80000001))
    u = f32_to_bits(f)
    return bits_to_f32(u - np.uint32(1) if f > np.float32(0.0) else u + np.uint32(1))


@numba.njit(inline="always")
def prefetch_ahead(arr, index_array, j):
    """Prefetch arr[index_array[j + PREFETCH_AHEAD]] when that position exists; index_array
    holds sort_ids()-style values (the index in the low 32 bits)."""
    k = j + PREFETCH_AHEAD
    if k < index_array.shape[0]:
        prefetch(arr, index_array[k] & 0xFFFFFFFF)


@intrinsic
def store4_nt(typingctx, arr, row, col, a, b, c, d):
    """Store the 4-vector (a, b, c, d) at arr[row, col:col+4] (a 2D float32 or float64
    array, aligned there to the vector's size: 16 or 32 bytes; the values of its dtype)
    with a non-temporal (streaming) store: written around the caches, so output the CPU
    stage does not read again neither evicts its working data nor is first read in from
    memory (a normal store's read for ownership).  Whole cache lines should be written by
    consecutive calls (the write-combining buffers then send them out whole)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 2 and arr.dtype in (types.float32, types.float64)):
        return None
    if not all(v == arr.dtype for v in (a, b, c, d)):
        return None
    sig = types.void(arr, row, col, a, b, c, d)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [args[1], args[2]],
                                       wraparound=False, boundscheck=False)
        elem = ir.FloatType() if aryty.dtype == types.float32 else ir.DoubleType()
        vty = ir.VectorType(elem, 4)
        vec = ir.Constant(vty, ir.Undefined)
        for k in range(4):
            vec = builder.insert_element(vec, args[3 + k], ir.Constant(ir.IntType(32), k))
        vptr = builder.bitcast(ptr, vty.as_pointer())
        st = builder.store(vec, vptr, align=4 * aryty.dtype.bitwidth // 8)
        st.set_metadata("nontemporal", builder.module.add_metadata([ir.Constant(ir.IntType(32), 1)]))
        return context.get_dummy_value()

    return sig, codegen


_X86 = platform.machine().lower() in ("x86_64", "amd64", "i386", "i686", "x86")


@intrinsic
def store_fence(typingctx):
    """Order the streaming stores before everything after (other threads, the Python code
    reading the arrays): sfence on x86, a full fence elsewhere."""
    def codegen(context, builder, signature, args):
        if _X86:
            fn = cgutils.get_or_insert_function(builder.module, ir.FunctionType(ir.VoidType(), []),
                                                "llvm.x86.sse.sfence")
            builder.call(fn, [])
        else:
            builder.fence("seq_cst")
        return context.get_dummy_value()

    return types.void(), codegen


@intrinsic
def fetch_add(typingctx, arr, idx, v):
    """Atomically arr[idx] += v (a 1D int64 array), returning the value before: the chunk
    claim of cpu_prep.share's kernels (numba has no atomics outside its parallel regions)."""
    if not (isinstance(arr, types.Array) and arr.ndim == 1 and arr.dtype == types.int64
            and isinstance(idx, types.Integer) and isinstance(v, types.Integer)):
        return None
    sig = types.int64(arr, idx, v)

    def codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        i = context.cast(builder, args[1], signature.args[1], types.intp)
        ptr = cgutils.get_item_pointer(context, builder, aryty, ary, [i],
                                       wraparound=False, boundscheck=False)
        val = context.cast(builder, args[2], signature.args[2], types.int64)
        return builder.atomic_rmw("add", ptr, val, "seq_cst")

    return sig, codegen
