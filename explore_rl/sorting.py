"""Stable sorts of non-negative integer keys by 16-bit radix passes.

A decision sorts ~10^5 integer keys several times (pairs of path poses and keyframes,
landmark observations, segment lengths). numpy's stable sort of 64-bit integers is a merge
sort (~15 ms for 10^5 keys); of 16-bit integers it is a radix sort (~2 ms). A stable sort's
permutation is unique, so sorting the low 16 bits, then (stably) the next 16, gives exactly
``np.argsort(keys, kind="stable")`` -- the same order, the same decisions.
"""

from __future__ import annotations

import numpy as np

RADIX_FROM = 512  # fewer keys: one merge sort is cheaper than the passes' set-up
DIGIT = 16  # bits per pass: numpy radix-sorts integers of up to 16 bits


def stable_argsort(keys: np.ndarray) -> np.ndarray:
    """``np.argsort(keys, kind="stable")``: the same permutation, by one or two 16-bit radix
    passes when the keys are non-negative integers below ``2**32`` (else numpy's own sort)."""
    keys = np.asarray(keys)
    if keys.ndim != 1 or len(keys) < RADIX_FROM or keys.dtype.kind not in "iu":
        return np.argsort(keys, kind="stable")
    low, high = int(keys.min()), int(keys.max())
    if low < 0 or high >= 1 << (2 * DIGIT):
        return np.argsort(keys, kind="stable")
    if high < 1 << DIGIT:
        return np.argsort(keys.astype(np.uint16), kind="stable")
    order = np.argsort((keys & 0xFFFF).astype(np.uint16), kind="stable")
    return order[np.argsort((keys[order] >> DIGIT).astype(np.uint16), kind="stable")]


def unique_first_inverse(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``np.unique(keys, return_index=True, return_inverse=True)`` of a 1-D integer array:
    the sorted distinct keys, the index of each one's first occurrence and each key's slot,
    from one :func:`stable_argsort` (the first of a run in a stable order is the earliest)."""
    keys = np.asarray(keys).reshape(-1)
    if len(keys) == 0:
        return keys.copy(), np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    order = stable_argsort(keys)
    ranked = keys[order]
    new = np.empty(len(keys), dtype=bool)
    new[0] = True
    np.not_equal(ranked[1:], ranked[:-1], out=new[1:])
    inverse = np.empty(len(keys), dtype=np.intp)
    inverse[order] = np.cumsum(new) - 1
    return ranked[new], order[new], inverse
