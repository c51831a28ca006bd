"""Each GPU struct, written by numpy and read by GLSL through the generated declaration,
comes back field by field: the dtype and the std430 layout agree on a real driver."""
import numpy as np
import pytest

from cpu_prep import layouts


def _components(dtype):
    """(field, component index or None, glsl scalar type) per scalar, in order."""
    out = []
    for f in dtype.names:
        base = dtype.fields[f][0]
        scalar = "float" if base.base == np.float32 else "uint"
        if base.shape:
            out += [(f, i, scalar) for i in range(base.shape[0])]
        else:
            out.append((f, None, scalar))
    return out


@pytest.mark.parametrize("name", list(layouts.STRUCTS))
def test_struct_round_trip_through_glsl(gl, rng, name):
    dtype = layouts.STRUCTS[name]
    comps = _components(dtype)
    body = []
    for k, (f, i, scalar) in enumerate(comps):
        expr = f"data[j].{f}" + (f"[{i}]" if i is not None else "")
        if scalar == "float":
            expr = f"floatBitsToUint({expr})"
        body.append(f"    outv[j * {len(comps)}u + {k}u] = {expr};")
    src = "\n".join([
        "#version 430", "layout(local_size_x = 1) in;", layouts.glsl_declarations(),
        f"layout(std430, binding = 0) readonly buffer In {{ {name} data[]; }};",
        "layout(std430, binding = 1) writeonly buffer Out { uint outv[]; };",
        "void main() {", "    uint j = gl_WorkGroupID.x;", *body, "}"])
    n = 5
    arr = np.frombuffer(rng.integers(0, 2**32, n * dtype.itemsize // 4, dtype=np.uint64)
                        .astype(np.uint32).tobytes(), dtype).copy()
    for f in dtype.names:                         # finite floats only (NaN bits may canonicalise)
        if dtype.fields[f][0].base == np.float32:
            arr[f] = rng.uniform(-1e3, 1e3, arr[f].shape)
    prog = gl.compute_shader(src)
    src_buf = gl.buffer(arr.tobytes())
    dst = gl.buffer(reserve=n * len(comps) * 4)
    src_buf.bind_to_storage_buffer(0)
    dst.bind_to_storage_buffer(1)
    prog.run(n)
    got = np.frombuffer(dst.read(), np.uint32).reshape(n, len(comps))
    want = np.stack([arr[f].view(np.uint32)[:, i] if i is not None else arr[f].view(np.uint32)
                     for f, i, _ in comps], 1)
    for o in (prog, src_buf, dst):
        o.release()
    assert np.array_equal(got, want)
