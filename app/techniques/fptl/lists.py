"""fptl's GPU formats, written once here (fptl_structs.glsl and fptl_format.glsl are
generated from them): its structs, the cells' flags and the states carried in band, and
the packed lists by index width (the chapter's R10G10B10A2 blocks, the wide formats) with
their decoding on the CPU, which reads what the shaders write."""
from __future__ import annotations

import numpy as np

from cpu_prep import layouts


TILE = 16                    # the chapter's tile: 64 invocations x 2x2 pixels
COARSE_BATCH = 64            # coarse lights in shared memory at once (the chapter's LDS list)
LIST_CAP = 24                # pruned lights in a tile's 8 R10G10B10A2 blocks
INDEX10_MAX = 1 << 10        # 10-bit indices: at most 1,024 visible lights
INDEX16_MAX = 1 << 16

# Cell flags: the tile's coarse list passed 64 (pruned batch by batch); the cell's list
# passed 24 (the rest in the spill); the spill pool ran short (the cell shades every light);
# some pixel of the cell shades (statistics).  SPILLED and POOL_FULL are also in the list's
# words (its state in band: what shading reads), with these values in the wide formats'
# count word.
FLAG_COARSE_OVER, FLAG_SPILLED, FLAG_POOL_FULL, FLAG_COVERED = 1, 2, 4, 8
STATE = FLAG_SPILLED | FLAG_POOL_FULL
# 10-bit blocks' count patterns of the two states (fptl_common.glsl): an empty block 0 before
# full blocks, which no plain list has (it fills its blocks front to back)
SPILLED_COUNTS = (0,) + (3,) * 7           # the 24 slots full, the rest in the spill
POOL_FULL_COUNTS = (0, 1) + (0,) * 6       # no list: every light

# The lists' formats by index width (index_bits): the chapter's 10-bit blocks, whose 2-bit
# count sits above three indices (bits 30-31), and the wide formats' count word, the listed
# entries in bits 0-7 and the state above them.  fptl_format.glsl is generated from these.
INDEX_FORMATS = (10, 16, 32)
BLOCK_COUNT_SHIFT = 30
COUNT_WORD_LISTED = 0xFF
COUNT_WORD_STATE_SHIFT = 8


def format_glsl() -> str:
    """fptl_format.glsl: per index width (FPTL_INDEX_BITS) the words of a cell's list, the
    words before its indices, the indices a word and their mask; the count fields; the two
    states' 10-bit count patterns.  fptl_common.glsl reads them; decode_* read the same."""
    out = []
    for k, bits in enumerate(INDEX_FORMATS):
        out.append(f"#{'elif' if k else 'if'} FPTL_INDEX_BITS == {bits}")
        out.append(layouts.glsl_defines({
            "FPTL_LIST_WORDS": list_words(bits), "FPTL_HEAD_WORDS": head_words(bits),
            "FPTL_PER_WORD": 32 // bits, "FPTL_INDEX_MASK": (1 << bits) - 1}).rstrip())
    out += ["#else", "#error FPTL_INDEX_BITS: not a list format", "#endif"]
    out.append(layouts.glsl_defines({
        "FPTL_BLOCK_COUNT_SHIFT": BLOCK_COUNT_SHIFT, "FPTL_COUNT_WORD_LISTED": COUNT_WORD_LISTED,
        "FPTL_COUNT_WORD_STATE_SHIFT": COUNT_WORD_STATE_SHIFT,
        "FPTL_SPILLED_SUM": sum(SPILLED_COUNTS)}).rstrip())
    for name, counts in (("FPTL_SPILLED_COUNTS", SPILLED_COUNTS),
                         ("FPTL_POOL_FULL_COUNTS", POOL_FULL_COUNTS)):
        out.append(f"const uint {name}[{len(counts)}] = uint[{len(counts)}]"
                   f"({', '.join(f'{c}u' for c in counts)});")
    return "\n".join(out) + "\n"


def index_bits(n: int) -> int:
    """Index width of a frame's lists: the chapter's 10 bits up to 1,024 visible lights, else
    16 up to 65,536, else 32 (never a wrapped index)."""
    return 10 if n <= INDEX10_MAX else 16 if n <= INDEX16_MAX else 32


def head_words(bits: int) -> int:
    """Words before a cell's indices: none at 10 bits (the counts are in the blocks' A2
    fields), the count word in the wide formats."""
    return 0 if bits == 10 else 1


def list_words(bits: int) -> int:
    """32-bit words of one cell's list of LIST_CAP lights, its count word included."""
    return head_words(bits) + LIST_CAP // (32 // bits)


def _words(words: np.ndarray, bits: int) -> np.ndarray:
    return np.ascontiguousarray(words).view(np.uint32).reshape(-1, list_words(bits)).astype(np.int64)


def decode_lists(words: np.ndarray, bits: int) -> tuple[np.ndarray, np.ndarray]:
    """(cells, LIST_CAP) light indices of every cell's packed list (fptl_common.glsl
    fptl_get) and the byte offset of the word each is read from."""
    per = 32 // bits
    w = _words(words, bits)
    k = np.arange(LIST_CAP)
    word, shift = head_words(bits) + k // per, (k % per) * (32 // per)
    idx = (w[:, word] >> shift) & ((1 << bits) - 1)
    off = (np.arange(len(w))[:, None] * list_words(bits) + word) * 4
    return idx, off


def decode_state(words: np.ndarray, bits: int) -> tuple[np.ndarray, np.ndarray]:
    """Per cell (entries in its blocks, state bits FLAG_SPILLED | FLAG_POOL_FULL) from its
    words, as fptl_shade.comp decodes them (fptl_common.glsl fptl_decode_counts /
    fptl_decode_count_word): at 10 bits the sum of the blocks' 2-bit counts, a pattern
    with an empty block 0 and full blocks after it a spilled list (24 listed), with one
    entry in block 1 a pool-full cell; in the wide formats the count word."""
    w = _words(words, bits)
    if bits != 10:
        return w[:, 0] & COUNT_WORD_LISTED, (w[:, 0] >> COUNT_WORD_STATE_SHIFT) & STATE
    counts = w >> BLOCK_COUNT_SHIFT
    total, c0 = counts.sum(1), counts[:, 0]
    marked = (c0 == 0) & (total != 0)
    spilled = marked & (total == sum(SPILLED_COUNTS))
    listed = np.where(marked, np.where(spilled, LIST_CAP, 0), total)
    state = np.where(marked, np.where(spilled, FLAG_SPILLED, STATE), 0)
    return listed.astype(np.int64), state.astype(np.int64)


def state_bytes(bits: int) -> int:
    """Bytes of a cell's words shading reads before its loops: the eight blocks whole (the
    sum of their counts), or the wide formats' count word."""
    return 4 * list_words(bits) if bits == 10 else 4


def shade_bytes(words: np.ndarray, heads: np.ndarray, bits: int) -> tuple[np.ndarray, np.ndarray]:
    """Per cell the bytes fptl_shade.comp reads of the culling structure (the same for every
    pixel of the cell), from the words and heads it reads: (list words, spill heads and
    spill).  10 bits: the 32 B of blocks; wide: the count word and the index words the
    list fills; a spilled cell also every scan window's head (8 B) and its spilled entries
    (4 B each); a pool-full cell reads its state and then every light (not counted here)."""
    listed, state = decode_state(words, bits)
    per = 32 // bits
    full = (state & FLAG_POOL_FULL) != 0
    lst = np.full(len(listed), state_bytes(bits), np.int64)
    if bits != 10:
        lst += np.where(full, 0, 4 * (-(-listed // per)))
    spilled = ((state & FLAG_SPILLED) != 0) & ~full
    h = np.ascontiguousarray(heads).view(np.uint32).reshape(-1, len(listed), 2).astype(np.int64)
    spill = np.where(spilled, 8 * h.shape[0] + 4 * h[..., 1].sum(0), 0)
    return lst, spill


# GPU structs of this technique (the GLSL is generated from them: fptl_structs.glsl).
FPTL_AABB = np.dtype([
    ("rect", np.float32, 4),     # x0, x1, y0, y1 in pixels (GL, y up), margins included
    ("depth", np.float32, 2),    # view depth range, conservative
    ("light", np.uint32),        # index into lights[] (depth order)
    ("pad", np.uint32),
])
FPTL_CELL = np.dtype([
    ("coarse", np.uint32),       # lights whose AABB meets the tile (every scan window)
    ("pruned", np.uint32),       # the cell's list length (listed + spilled)
    ("flags", np.uint32),        # FLAG_*
    ("reserved", np.uint32),
])
STRUCTS = {"FptlAabb": FPTL_AABB, "FptlCell": FPTL_CELL}
SPILL_HEAD = np.dtype((np.uint32, 2))      # (first, count) in fptl_spill
CATEGORY_SEEN = np.dtype((np.uint32, 2))   # per cell: lights found of category 0 and 1


def structs_glsl() -> str:
    """fptl_structs.glsl: the structs and constants above, written once here."""
    structs = "\n".join(layouts.glsl_struct(n, d) for n, d in STRUCTS.items()) + "\n"
    tile = layouts.glsl_defines({"FPTL_TILE": TILE}, suffix="")     # an int: ivec2 pixel maths
    return structs + tile + layouts.glsl_defines({
        "FPTL_CAP": LIST_CAP, "FPTL_BATCH": COARSE_BATCH, "FPTL_COARSE_OVER": FLAG_COARSE_OVER,
        "FPTL_SPILLED": FLAG_SPILLED, "FPTL_POOL_FULL": FLAG_POOL_FULL,
        "FPTL_COVERED": FLAG_COVERED})
