"""Blocked evaluation of element-wise kernels over flattened batches.

The hot conversions evaluate their closed forms block by block so that the
temporaries of one block stay in the processor cache; every block is
validated before it is used. Batches of at least :data:`COMPILED_MIN`
rotations go to the compiled kernels of :mod:`._kernels` instead (one loop,
no temporaries), imported on first use.
"""

from __future__ import annotations

import functools

#: Number of batch elements per block (temporaries of 32 KiB each).
BLOCK = 4096

#: Smallest batch (number of rotations) evaluated by the compiled kernels.
#: Once loaded, the compiled loop is the faster path at every batch size
#: (a call costs 3-5 us against 70-150 us of numpy calls for a few
#: rotations), but its first call in a process imports numba and loads the
#: kernels from numba's cache (about 1 s; a few seconds for the very first
#: compile). Smaller batches stay on the numpy path, so that a scene or a
#: notebook converting a handful of rotations at a time never pays that.
COMPILED_MIN = 64


def blocks(n):
    """Yield ``(start, stop)`` index pairs covering ``range(n)`` in blocks."""
    for start in range(0, n, BLOCK):
        yield start, min(n, start + BLOCK)


def compiled(n):
    """The module of compiled kernels if a batch of ``n`` rotations should
    use them, else None (imported, and numba with it, on the first call that
    returns it)."""
    if n < COMPILED_MIN:
        return None
    return _kernels_module()


@functools.cache
def _kernels_module():
    from . import _kernels

    return _kernels
