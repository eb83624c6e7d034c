"""The buffers' views cut by intrinsics (biped.control.buffers): ``_take2``/``_take3`` build the
view numpy's reshape of the slice gives (oracle: numpy), sharing the buffer's memory and keeping it
alive when returned to Python; ``borrowed`` drops the owner without changing the data."""

from __future__ import annotations

import gc

import numpy as np
import pytest
from numba import njit

from biped.control.buffers import _take2, _take3, borrowed


@njit(cache=False)
def _views(buf, o):
    a, o2 = _take2(buf, o, 3, 4)
    b, o3 = _take3(buf, o2, 2, 2, 3)
    return a, b, o3


@njit(cache=False)
def _sum_borrowed(buf, o):
    a, _ = _take3(borrowed(buf), o, 2, 3, 4)  # type: ignore[call-arg]
    a[1, 2, 3] += 1.0  # writes reach the buffer
    return a.sum()


def test_views_are_numpys_reshape_and_share_the_buffer():
    buf = np.arange(40.0)
    a, b, end = _views(buf, 5)
    assert end == 5 + 12 + 12
    np.testing.assert_array_equal(a, buf[5:17].reshape(3, 4))
    np.testing.assert_array_equal(b, buf[17:29].reshape(2, 2, 3))
    assert a.strides == (32, 8) and b.strides == (48, 24, 8) and a.flags.c_contiguous
    a[1, 1] = -1.0
    assert buf[10] == -1.0  # the same memory
    del buf
    gc.collect()
    assert b[1, 1, 2] == 28.0  # the views keep the buffer alive


def test_a_view_past_the_end_is_an_index_error():
    with pytest.raises(IndexError, match="past the buffer's end"):
        _views(np.zeros(20), 0)


def test_borrowed_views_read_and_write_the_buffer():
    buf = np.arange(30.0)
    assert _sum_borrowed(buf, 4) == buf[4:28].sum()
    assert buf[4 + 12 + 8 + 3] == 4 + 12 + 8 + 3 + 1.0
