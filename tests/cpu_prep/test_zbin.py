"""Drobot's Z-bins and flat bit arrays on the CPU (cpu_prep.zbin): the slides' LUT format and
memory table, the 16-bit id fallback, the memory budget, conservative bins against the GPU's
float32 arithmetic, the bit rasterisation and the word masks.  No GL."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from cpu_prep import zbin as zb
from cpu_prep.limits import MAX_STORAGE_BYTES, LimitError

MAX_ID = zb.ZBIN_NARROW_EMPTY


# ---- the slides' memory table ------------------------------------------------------------

def test_memory_table_numbers():
    """F+ Renderer: Memory Performance, 1080p, a 256-bit array: 240 x 135 tiles of 8 px,
    1,036,800 bytes of bit arrays; 8096 z-bins of 2 x 16 bit, 32,384 bytes."""
    assert zb.tiles_for(1920, 1080, 8) == (240, 135)
    assert zb.words_for(256) == 8
    assert zb.bits_bytes(1920, 1080, 8, 256) == 1_036_800
    lut, _ = zb.zbin_lut(np.zeros(256, np.float32), np.ones(256, np.float32), 8096, 100.0)
    assert lut.dtype == np.uint32 and lut.shape == (8096,) and lut.nbytes == 32_384
    # the figure for 65,536 lights in 8 px tiles
    assert zb.bits_bytes(1920, 1080, 8, 65_536) == 265_420_800


def test_budget_doubles_the_tile_like_urp():
    mib = 1 << 20
    # 256 lights fit any sane budget in 8 px tiles
    assert zb.choose_tile(1920, 1080, 256, 8, 32 * mib) == 8
    # 65,536 lights: 8 px = 253 MiB, 16 px = 63.75 MiB, 32 px = 15.9 MiB
    assert zb.choose_tile(1920, 1080, 65_536, 8, 32 * mib) == 32
    assert zb.choose_tile(1920, 1080, 65_536, 8, 63 * mib) == 32
    assert zb.choose_tile(1920, 1080, 65_536, 8, 64 * mib) == 16
    assert zb.choose_tile(1920, 1080, 65_536, 8, 16 * mib) == 32
    assert zb.choose_tile(1920, 1080, 65_536, 8, 15 * mib) == 64
    for budget in (1, 1000, mib, 32 * mib):
        t = zb.choose_tile(1920, 1080, 65_536, 8, budget)
        need = zb.bits_bytes(1920, 1080, t, 65_536)
        assert need <= budget or t >= 1920               # fits, or one tile is the screen
        assert need <= MAX_STORAGE_BYTES
        assert t == 8 or zb.bits_bytes(1920, 1080, t // 2, 65_536) > budget   # the smallest that fits
    # a budget past the storage-block limit is held to it
    assert zb.bits_bytes(1920, 1080, zb.choose_tile(1920, 1080, 1 << 22, 8, 1 << 40), 1 << 22) <= MAX_STORAGE_BYTES


def test_slices_multiply_the_bit_arrays():
    """raster's cluster rasterizer: tiles x slices x words fit the budget (16 slices of 32 px
    tiles at 1080p, 4,096 lights: 60 x 34 x 16 x 128 x 4 B = 15.9 MiB)."""
    mib = 1 << 20
    assert zb.choose_tile(1920, 1080, 4096, 32, 32 * mib, slices=16) == 32
    assert zb.choose_tile(1920, 1080, 4096, 32, 15 * mib, slices=16) == 64
    for slices in (1, 3, 16, 64):
        t = zb.choose_tile(1920, 1080, 65_536, 8, 32 * mib, slices)
        assert zb.bits_bytes(1920, 1080, t, 65_536) * slices <= 32 * mib or t >= 1920
        assert t == 8 or zb.bits_bytes(1920, 1080, t // 2, 65_536) * slices > 32 * mib


def test_no_budget_can_make_a_buffer_past_the_storage_limit():
    with pytest.raises(LimitError, match="storage-block"):
        zb.choose_tile(4, 4, (MAX_STORAGE_BYTES * 8) + 64, 4, 1 << 40)


# ---- the LUT --------------------------------------------------------------------------------

def test_slides_lut_example():
    """The slides' table: 5 -> 3|5, 4 -> 1|2, 3 -> 1|1, 2 -> MAX|0, 1 -> 0|0, 0 -> MAX|0."""
    b0 = np.array([1, 3, 4, 5, 5, 5])
    b1 = np.array([1, 4, 4, 5, 5, 5])
    lo, hi = zb.bin_ranges(b0, b1, 6)
    lut = zb.pack_lut(lo, hi, 6)
    expect = {5: (3, 5), 4: (1, 2), 3: (1, 1), 2: (MAX_ID, 0), 1: (0, 0), 0: (MAX_ID, 0)}
    for b, (mn, mx) in expect.items():
        assert lut[b] == mn | (mx << 16), (b, hex(lut[b]))
    mn, mx = zb.unpack_lut(lut)
    assert list(mn > mx) == [True, False, True, False, False, False]   # empty bins: min > max


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 300), bins=st.integers(1, 80))
def test_bin_ranges_match_brute_force(seed, n, bins):
    rng = np.random.default_rng(seed)
    b0 = rng.integers(-1, bins, n)
    b1 = np.minimum(b0 + rng.integers(-2, bins, n), bins - 1)
    b0 = np.maximum(b0, 0)
    lo, hi = zb.bin_ranges(b0, b1, bins)
    for b in range(bins):
        ids = np.nonzero((b0 <= b) & (b <= b1))[0]
        if len(ids):
            assert (lo[b], hi[b]) == (ids.min(), ids.max())
        else:
            assert lo[b] > hi[b]


@pytest.mark.parametrize("n,wide", [(1, False), (65_535, False), (65_536, False),
                                    (65_537, True), (70_000, True)])
def test_ids_past_16_bits_take_the_wide_lut(n, wide):
    """Up to 65,536 lights (ids 0..65,535) the slides' 2 x 16-bit entry; past that 2 x 32-bit
    entries, the same (min, max) per bin: never a wrapped id."""
    rng = np.random.default_rng(n)
    d = np.sort(rng.uniform(1.0, 99.0, n)).astype(np.float32)
    lo_d, hi_d = d - np.float32(0.3), d + np.float32(0.3)
    lut, scale = zb.zbin_lut(lo_d, hi_d, 512, 100.0)
    assert zb.is_wide(n) == wide
    assert lut.shape == ((512, 2) if wide else (512,))
    assert lut.nbytes == 512 * (8 if wide else 4)
    b0, b1 = zb.light_bins(lo_d, hi_d, scale, 512)
    want_lo, want_hi = zb.bin_ranges(b0, b1, 512)
    mn, mx = zb.unpack_lut(lut)
    full = want_lo <= want_hi
    assert np.array_equal(mn[full], want_lo[full]) and np.array_equal(mx[full], want_hi[full])
    assert (mn[~full] > mx[~full]).all()
    assert mx.max() == n - 1                       # the last light keeps its id


def test_the_last_narrow_id_is_not_the_empty_marker():
    """Light 65,535 alone in a bin: min = max = 65,535, not empty (empty is MAX | 0)."""
    n = 65_536
    b0 = np.full(n, 0)
    b1 = np.full(n, 0)
    b0[-1] = b1[-1] = 3
    lut = zb.pack_lut(*zb.bin_ranges(b0, b1, 4), n)
    assert lut[3] == 0xFFFF | (0xFFFF << 16)
    assert lut[1] == lut[2] == MAX_ID
    mn, mx = zb.unpack_lut(lut)
    assert mn[3] == mx[3] == 65_535


def gpu_bin(depth, scale, bins):
    """The shader: uint(min(depth * u_bin_scale, float(bins - 1))), all float32."""
    p = np.float32(depth) * np.float32(scale)
    return np.minimum(p, np.float32(bins - 1)).astype(np.int64)


@settings(max_examples=200, deadline=None)
@given(lo=st.floats(-50.0, 5000.0, width=32), span=st.floats(0.0, 500.0, width=32),
       t=st.floats(0.0, 1.0), bins=st.sampled_from([1, 7, 512, 8096, 65536]),
       max_depth=st.floats(0.5, 3000.0))
def test_bins_are_conservative_for_the_gpu(lo, span, t, bins, max_depth):
    """A pixel at float32 depth d in a light's float32 range [lo, hi] lands, as the GPU
    computes it, in one of the light's bins; so does every bin boundary nearby."""
    lo32 = np.float32(lo)
    hi32 = np.float32(lo + span)
    scale = zb.bin_scale(bins, max_depth)
    b0, b1 = zb.light_bins(np.array([lo32]), np.array([hi32]), scale, bins)
    cands = [np.float32(lo32 + (hi32 - lo32) * t), lo32, hi32]
    # depths on the bin boundaries inside [lo, hi], and one ulp either side
    for k in (np.floor(lo32 * float(scale)), np.floor(hi32 * float(scale))):
        edge = np.float32(k / float(scale))
        for e in (edge, np.nextafter(edge, np.float32(-np.inf)), np.nextafter(edge, np.float32(np.inf))):
            cands.append(e)
    for d in cands:
        if not (lo32 <= d <= hi32) or d <= 0:        # the GPU bins covered pixels, depth > 0
            continue
        b = gpu_bin(d, scale, bins)
        assert b0[0] <= b <= b1[0], (d, b, b0[0], b1[0])


def test_bin_edges_where_the_gpu_rounds_up():
    """Depths just below a bin boundary (exactly: depth * scale < k) whose float32 product
    rounds up to k on the GPU: the light ending there must still own bin k."""
    rng = np.random.default_rng(7)
    rounded_up = 0
    for _ in range(3000):
        bins = int(rng.choice([512, 8096, 65536]))
        scale = zb.bin_scale(bins, rng.uniform(1.0, 3000.0))
        k = int(rng.integers(1, bins))
        d = np.float32(k / float(scale))
        while float(d) * float(scale) >= k:
            d = np.nextafter(d, np.float32(-np.inf))
        g = gpu_bin(d, scale, bins)
        rounded_up += int(g == k)
        b0, b1 = zb.light_bins(np.array([d]), np.array([d]), scale, bins)
        assert b0[0] <= g <= b1[0], (bins, float(scale), k, float(d))
    assert rounded_up > 100          # the case is real: float32 puts these depths in bin k


def test_depths_past_the_range_land_in_the_last_bin():
    scale = zb.bin_scale(16, 100.0)
    b0, b1 = zb.light_bins(np.float32([150.0, 90.0, -5.0]), np.float32([160.0, 1e6, 0.5]), scale, 16)
    assert list(b0) == [15, 14, 0] and list(b1) == [15, 15, 0]
    assert gpu_bin(1e5, scale, 16) == 15


# ---- bit arrays -----------------------------------------------------------------------------

@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(0, 200), tx=st.integers(1, 9),
       ty=st.integers(1, 7))
def test_tile_bits_match_brute_force(seed, n, tx, ty):
    rng = np.random.default_rng(seed)
    x0 = rng.integers(-2, tx + 1, n)
    y0 = rng.integers(-2, ty + 1, n)
    boxes = np.zeros((n, 6), np.int32)
    boxes[:, 0] = np.maximum(x0, 0)
    boxes[:, 1] = np.minimum(x0 + rng.integers(-1, 4, n), tx - 1)
    boxes[:, 2] = np.maximum(y0, 0)
    boxes[:, 3] = np.minimum(y0 + rng.integers(-1, 4, n), ty - 1)
    bits = zb.tile_bits(boxes, tx, ty, n)
    assert bits.dtype == np.uint32 and len(bits) == tx * ty * zb.words_for(n)
    for t in range(tx * ty):
        x, y = t % tx, t // tx
        want = np.nonzero((boxes[:, 0] <= x) & (x <= boxes[:, 1]) &
                          (boxes[:, 2] <= y) & (y <= boxes[:, 3]))[0]
        assert np.array_equal(zb.bits_of_tile(bits, t, n), want)


def test_bit_n_is_light_n():
    """70 lights in tile 0 of a 2x1 grid, except lights 3, 5, 40 and 69 in tile 1."""
    boxes = np.array([[0, 0, 0, 0, 0, 0]] * 70, np.int32)
    boxes[[3, 5, 40, 69], 0:2] = 1
    bits = zb.tile_bits(boxes, 2, 1, 70).reshape(2, 3)
    assert bits[1, 0] == (1 << 3) | (1 << 5) and bits[1, 1] == 1 << 8 and bits[1, 2] == 1 << 5


# ---- the word masks ---------------------------------------------------------------------------

def test_bit_field_mask_wraps_at_32():
    assert zb.bit_field_mask(32, 0) == 0            # GCN: width & 31: the listing's manual case
    assert zb.bit_field_mask(3, 4) == 0b1110000
    assert zb.bit_field_mask(6, 31) == 1 << 31      # bits shifted past 31 are lost


def bits_of(mask):
    return {i for i in range(32) if mask >> i & 1}


@settings(max_examples=300, deadline=None)
@given(mn=st.integers(0, 200), mx=st.integers(0, 200), word=st.integers(0, 7))
def test_word_masks(mn, mx, word):
    """range_mask is exactly the lights mn..mx of the word; the listing's printed mask holds
    them too (conservative) and sometimes more."""
    want = {i - 32 * word for i in range(mn, mx + 1) if 32 * word <= i < 32 * word + 32}
    assert bits_of(zb.range_mask(mn, mx, word)) == want
    assert want <= bits_of(zb.zbin_word_mask(mn, mx, word))


def test_the_printed_mask_leaks():
    """The listing as printed: bit 31 of a word before the range, and the tail of its last
    word past max (why range_mask is the default)."""
    assert zb.zbin_word_mask(40, 45, 0) == 1 << 31          # no light of 40..45 is in word 0
    assert zb.range_mask(40, 45, 0) == 0
    assert bits_of(zb.zbin_word_mask(10, 40, 1)) == set(range(31))   # 32..40 wanted, 32..62 given
    assert bits_of(zb.range_mask(10, 40, 1)) == set(range(9))
    assert zb.zbin_word_mask(MAX_ID, 0, 3) == zb.range_mask(MAX_ID, 0, 3) == 0   # empty bin
    assert zb.range_mask(zb.ZBIN_WIDE_EMPTY_MIN, 0, 0) == 0
