"""The pass timer's two clocks: GL timer queries (a real GPU's) and the CPU's around a finish."""
import numpy as np

from app.pipeline import gl


def _work(ctx):
    """A small compute dispatch that writes a buffer, so the timed pass does GPU work."""
    prog = ctx.compute_shader("""#version 430
        layout(local_size_x = 64) in;
        layout(std430, binding = 0) buffer B { float v[]; };
        void main() { uint i = gl_GlobalInvocationID.x; v[i] = sqrt(float(i)); }""")
    buf = ctx.buffer(reserve=64 * 64 * 4)
    buf.bind_to_storage_buffer(0)
    return prog, buf


def test_timer_queries_time_every_pass_and_sum_repeats():
    ctx = gl.context()
    prog, buf = _work(ctx)
    timer = gl.PassTimer(ctx, use_queries=True)
    for _ in range(3):                      # one query object serves pass after pass
        timer.run("a", lambda: prog.run(64))
    timer.run("b", lambda: prog.run(64))
    ms = timer.take()
    assert set(ms) == {"a", "b"} and all(np.isfinite(v) and v >= 0.0 for v in ms.values())
    assert timer.take() == {}
    np.testing.assert_allclose(np.frombuffer(buf.read(), np.float32)[:4], np.sqrt([0, 1, 2, 3]))


def test_cpu_clock_where_queries_are_off():
    ctx = gl.context()
    prog, _ = _work(ctx)
    timer = gl.PassTimer(ctx, use_queries=False)
    timer.run("a", lambda: prog.run(64))
    assert timer.take()["a"] > 0.0
