"""The fused loop: Phases 2-6 compiled, for the CPU and the GPU.

What the compiled and GPU engines share, so that neither imports the other: the generated
modules' loading and cache (:mod:`.modules`), where the generated code finds things and the
numbers it reads (:mod:`.layout`), the pieces of source both write and the fused functions'
parameter names (:mod:`.source`), the helpers their generated code calls (:mod:`.runtime`),
the arguments matched to those names (:mod:`.arguments`), and the engines' common base: the
tree's arrays and the bookkeeping of a fused run (:mod:`.engine`). This package imports bt/,
kernels, jit, models, recording, state, world and datalink, never engines/ (which may import
it).
"""
