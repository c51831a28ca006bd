"""The frame pipeline: the GL context and its limits, the shader loader, the frame graph's
vocabulary (passes.py), the G-buffer and the renderer that executes declared passes.

Nothing is imported here, so that `from app.pipeline.passes import ...` (which the CPU-only
benchmark does through the techniques) does not load OpenGL.
"""
