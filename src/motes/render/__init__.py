"""Software rendering: camera, sprites, opaque geometry, metaballs, tone mapping.

Everything runs on the CPU in compiled kernels and needs no display, so frames are
reproducible and testable.
"""
