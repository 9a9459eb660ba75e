"""Blocked evaluation of element-wise kernels over flattened batches.

The hot conversions evaluate their closed forms block by block so that the
temporaries of one block stay in the processor cache; every block is
validated before it is used.
"""

from __future__ import annotations

#: Number of batch elements per block (temporaries of 32 KiB each).
BLOCK = 4096


def blocks(n):
    """Yield ``(start, stop)`` index pairs covering ``range(n)`` in blocks."""
    for start in range(0, n, BLOCK):
        yield start, min(n, start + BLOCK)
