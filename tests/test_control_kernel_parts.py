"""The compiled kernel's parts: the inlined spatial products of biped.spatial against the 6x6
matrices written out with numpy (W eq. 3.2, 3.7, 3.8), the 6x6 Cholesky solve against
numpy.linalg.solve, and the compiled buffer unpack against the layout table it must follow."""

from __future__ import annotations

import numpy as np
import pytest

from biped import spatial
from biped.control.recursions import layout, unpack


def _rot(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def _hat(w):
    return np.cross(np.eye(3), w)  # row i: e_i x w, so (w^ v)_i = (e_i x w) . v = (w x v)_i


def _ad(R, p):
    """W eq. 3.7 with numpy: [[R, p^ R], [0, R]]."""
    A = np.zeros((6, 6))
    A[:3, :3] = A[3:, 3:] = R
    A[:3, 3:] = _hat(p) @ R
    return A


def test_hat_is_the_cross_product():
    rng = np.random.default_rng(0)
    a, b = rng.normal(size=3), rng.normal(size=3)
    np.testing.assert_allclose(_hat(a) @ b, np.cross(a, b), atol=1e-15)
    np.testing.assert_allclose(spatial.cross(a, b), np.cross(a, b), atol=1e-15)


@pytest.mark.parametrize("seed", range(5))
def test_adjoint_products_match_the_matrices(seed):
    rng = np.random.default_rng(seed)
    R, p = _rot(rng), rng.normal(size=3)
    A = _ad(R, p)
    x, out = rng.normal(size=6), np.empty(6)
    for fn, M in (
        (spatial.adjoint_mul, A),
        (spatial.adjoint_inv_mul, np.linalg.inv(A)),
        (spatial.adjoint_T_mul, A.T),
        (spatial.adjoint_inv_T_mul, np.linalg.inv(A).T),
    ):
        fn(R, p, x, out)
        np.testing.assert_allclose(out, M @ x, rtol=1e-12, atol=1e-12, err_msg=fn.__name__)
    np.testing.assert_allclose(spatial.rot_mul(R, x[:3]), R @ x[:3], atol=1e-14)
    np.testing.assert_allclose(spatial.rot_T_mul(R, x[:3]), R.T @ x[:3], atol=1e-14)
    # the congruence of W Alg. 3: out += A^T M A with A = Ad_{g^-1}
    M = rng.normal(size=(6, 6))
    M = M @ M.T
    base = rng.normal(size=(6, 6))
    out66 = base.copy()
    spatial.adjoint_inv_congruence_add(R, p, M, out66, np.empty((6, 6)), np.empty((3, 3)))
    Ai = np.linalg.inv(A)
    np.testing.assert_allclose(out66, base + Ai.T @ M @ Ai, rtol=1e-12, atol=1e-11)


def test_cholesky6_solve():
    rng = np.random.default_rng(3)
    B = rng.normal(size=(6, 6))
    A = B @ B.T + 0.1 * np.eye(6)
    b, y = rng.normal(size=6), np.empty(6)
    assert spatial.cholesky6_solve(A.copy(), b, y)
    np.testing.assert_allclose(y, np.linalg.solve(A, b), rtol=1e-10)
    indefinite = A.copy()
    indefinite[4, 4] = -1.0
    assert not spatial.cholesky6_solve(indefinite, b, y)


@pytest.mark.parametrize("n", [2, 7, 13])
def test_unpack_follows_layout(n):
    """Every named view that the kernel (and the controller's debugging methods) uses sits where
    layout() puts it, with its shape, and the fields tile each buffer exactly."""
    lay = layout(n)
    mi = np.arange(lay["ints"]["_size"][0], dtype=np.int64)
    mi[0] = n
    bufs = {
        "ints": mi,
        "model": np.arange(float(lay["model"]["_size"][0])),
        "work": np.arange(float(lay["work"]["_size"][0])),
        "out": np.arange(float(lay["out"]["_size"][0])),
    }
    views = unpack(bufs["ints"], bufs["model"], bufs["work"], bufs["out"])
    for name, nt in zip(("ints", "model", "work", "out"), views, strict=True):
        assert list(nt._fields) == [k for k in lay[name] if k != "_size"], name
        covered = np.zeros(lay[name]["_size"][0], dtype=int)
        for field, view in zip(nt._fields, nt, strict=True):
            off, shape = lay[name][field]
            assert view.shape == shape, (name, field)
            assert np.shares_memory(view, bufs[name]), (name, field)
            idx = np.arange(off, off + int(np.prod(shape))).reshape(shape)
            if name == "ints" and field == "n":
                assert view[0] == n
                idx = idx * 0 + n
            np.testing.assert_array_equal(view, idx, err_msg=f"{name}.{field}")
            covered[off : off + view.size] += 1
        assert np.all(covered == 1), name
