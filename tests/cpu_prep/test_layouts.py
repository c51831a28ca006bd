"""Every GPU struct: numpy dtype offsets equal std430's for the generated GLSL; node bits
round-trip and refuse to wrap."""
import numpy as np
import pytest
from hypothesis import given, strategies as st

from cpu_prep import layouts, limits


@pytest.mark.parametrize("name", list(layouts.STRUCTS))
def test_dtype_matches_std430(name):
    dtype = layouts.STRUCTS[name]
    offsets, stride = layouts.std430_offsets(dtype)
    assert stride == dtype.itemsize
    assert offsets == {f: dtype.fields[f][1] for f in dtype.names}


def test_glsl_struct_lists_every_field_in_order():
    text = layouts.glsl_struct("TreeNode", layouts.TREE_NODE)
    assert text.splitlines()[1:5] == ["    float min_depth;", "    float max_depth;",
                                      "    uint first_light;", "    uint bits;"]


def test_std430_pads_vec4_after_scalar():
    dt = np.dtype([("a", np.float32), ("b", np.float32, 4)])
    offsets, stride = layouts.std430_offsets(dt)
    assert offsets == {"a": 0, "b": 16} and stride == 32
    assert offsets["b"] != dt.fields["b"][1]   # the test would catch such a dtype


@given(st.booleans(), st.integers(0, limits.NODE_MAX_LIGHTS), st.integers(0, limits.NODE_MAX_SKIP))
def test_node_bits_round_trip(leaf, count, skip):
    bits = layouts.pack_node_bits(leaf, count, skip)
    l2, c2, s2 = layouts.unpack_node_bits(bits)
    assert (bool(l2), int(c2), int(s2)) == (leaf, count, skip)


def test_node_bits_listing1_order():
    # isLeaf bit 0, count bits 1-16, skip bits 17-31
    assert int(layouts.pack_node_bits(1, 0, 0)) == 1
    assert int(layouts.pack_node_bits(0, 1, 0)) == 2
    assert int(layouts.pack_node_bits(0, 0, 1)) == 1 << 17


@pytest.mark.parametrize("count,skip", [(limits.NODE_MAX_LIGHTS + 1, 1), (1, limits.NODE_MAX_SKIP + 1), (-1, 1)])
def test_node_bits_refuse_to_wrap(count, skip):
    with pytest.raises(limits.LimitError):
        layouts.pack_node_bits(1, count, skip)
