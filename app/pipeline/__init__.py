"""The frame pipeline: the GL context and its limits, the shader loader, the frame graph's
vocabulary (passes.py), the G-buffer and the renderer that executes declared passes; phases.py
counts where a process's time goes by named phase (the renderer's compile, render, timing and
build; the benchmark's check and replay).

Nothing is imported here, so that `from app.pipeline.passes import ...` (which the CPU-only
benchmark does through the techniques) does not load OpenGL.
"""
