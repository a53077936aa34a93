"""Tests of the Jacobi transform and the formation matrices (eqs. 11-20)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from numpy.testing import assert_allclose

from auv_hinf.exceptions import FormationError
from auv_hinf.models.jacobi import (
    DENSE_MAX_N,
    JacobiTransform,
    block_diag_stack,
    closest_pair,
    formation_matrices,
    offsets_from_shape,
    regular_polygon,
    shape_from_offsets,
)
from auv_hinf.models.vehicle import inertial_block

KINDS = ["paper", "orthonormal"]
EXACT_RTOL = 1e-12


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", [2, 3, 4, 6, 11])
def test_round_trip_and_centroid(kind, n, rng):
    t = JacobiTransform(n, kind)
    p = rng.normal(scale=20, size=(5, n, 2))
    x = t.to_jacobi(p)
    assert_allclose(t.to_positions(x), p, rtol=1e-12, atol=1e-10)
    assert_allclose(x[:, -1, :], p.mean(axis=1), rtol=1e-12, atol=1e-12)


def test_paper_rows_for_three_vehicles():
    t = JacobiTransform(3, "paper")
    p = np.array([[25.0, 5.0], [-5.0, 10.0], [10.0, 8.0]])
    x = t.to_jacobi(p)
    assert_allclose(x[0], p[0] - p[1])
    assert_allclose(x[1], (p[0] + p[1]) / 2 - p[2])


@pytest.mark.parametrize("n", [2, 3, 5, 9])
def test_orthonormal_rows(n):
    t = JacobiTransform(n, "orthonormal")
    shape_rows = t.phi[:-1]
    assert_allclose(shape_rows @ shape_rows.T, np.eye(n - 1), atol=1e-12)
    assert_allclose(shape_rows @ np.ones(n), 0.0, atol=1e-12)
    # Phi Phi^T = diag(1, ..., 1, 1/N) so cond(Phi) = sqrt(N)
    assert t.cond == pytest.approx(np.sqrt(n), rel=1e-12)


def test_shapes_translation_invariant(rng):
    t = JacobiTransform(4, "paper")
    off = rng.normal(size=(4, 2))
    assert_allclose(shape_from_offsets(off, t), shape_from_offsets(off + [3.0, -7.0], t), atol=1e-12)  # noqa: RUF005
    back = offsets_from_shape(shape_from_offsets(off, t), t)
    assert_allclose(back, off - off.mean(axis=0), atol=1e-12)


def test_regular_polygon():
    pts = regular_polygon(6, 10.0)
    assert_allclose(np.linalg.norm(pts, axis=1), 10.0)
    assert_allclose(pts.mean(axis=0), 0.0, atol=1e-12)
    side = np.linalg.norm(np.roll(pts, -1, axis=0) - pts, axis=1)
    assert_allclose(side, 10.0, rtol=1e-12)  # hexagon side = radius


@pytest.mark.parametrize("kind", KINDS)
def test_formation_matrices_definition(vehicle, kind, rng):
    n = 4
    t = JacobiTransform(n, kind)
    psi, u = rng.uniform(-3, 3, n), rng.uniform(0, 2, n)
    v, r = rng.uniform(-1, 1, n), rng.uniform(-0.5, 0.5, n)
    fm = formation_matrices(vehicle, psi, u, v, r, t)
    big_g = block_diag_stack(inertial_block(vehicle, psi, u, v, r))
    assert_allclose(fm.A, t.matrix @ big_g @ np.linalg.inv(t.matrix), rtol=1e-10, atol=1e-12)
    # Gamma is nonsingular: |det| = |det Phi|^2 / (m11 m22)^N
    det = np.linalg.det(fm.Gamma)
    expected = np.linalg.det(t.phi) ** 2 / (vehicle.m11 * vehicle.m22) ** n
    assert abs(det) == pytest.approx(abs(expected), rel=1e-9)
    assert abs(det) > 0


def test_formation_matrices_vectorised(vehicle, rng):
    t = JacobiTransform(3)
    psi, u = rng.uniform(-3, 3, (7, 3)), rng.uniform(0, 2, (7, 3))
    v, r = rng.uniform(-1, 1, (7, 3)), rng.uniform(-0.5, 0.5, (7, 3))
    fm = formation_matrices(vehicle, psi, u, v, r, t)
    assert fm.A.shape == (7, 6, 6)
    one = formation_matrices(vehicle, psi[4], u[4], v[4], r[4], t)
    assert_allclose(fm.A[4], one.A, rtol=EXACT_RTOL)
    assert_allclose(fm.Gamma[4], one.Gamma, rtol=EXACT_RTOL)


def test_common_rotation_commutes(vehicle, rng):
    """A rotation of every heading by the same angle conjugates A by blockdiag(R)."""
    t = JacobiTransform(3, "paper")
    psi, u, v, r = rng.uniform(-3, 3, 3), rng.uniform(0, 2, 3), rng.uniform(-1, 1, 3), rng.uniform(-0.5, 0.5, 3)
    a0 = formation_matrices(vehicle, psi, u, v, r, t).A
    a1 = formation_matrices(vehicle, psi + 0.9, u, v, r, t).A
    assert np.linalg.norm(a1, 2) == pytest.approx(np.linalg.norm(a0, 2), rel=1e-12)


@pytest.mark.parametrize(
    "args, pattern",
    [((1,), "must be >= 2"), ((0,), "must be >= 2"), ((2.5,), "must be an integer"), ((3, "weird"), "Jacobi kind")],
)
def test_bad_transform(args, pattern):
    with pytest.raises(ValueError, match=pattern):
        JacobiTransform(*args)


def test_bad_stack_shape():
    with pytest.raises(ValueError, match=r"shape \(\.\.\., 3, 2\)"):
        JacobiTransform(3).to_jacobi(np.zeros((4, 2)))


def test_bad_polygon():
    with pytest.raises(ValueError, match="radius must be > 0"):
        regular_polygon(4, -1.0)


@given(
    n=st.integers(2, 12),
    kind=st.sampled_from(KINDS),
    seed=st.integers(0, 2**32 - 1),
)
def test_property_round_trip(n, kind, seed):
    rng = np.random.default_rng(seed)
    t = JacobiTransform(n, kind)
    p = rng.normal(scale=100, size=(n, 2))
    assert_allclose(t.to_positions(t.to_jacobi(p)), p, rtol=1e-10, atol=1e-8)
    assert_allclose(t.to_jacobi(p)[-1], p.mean(axis=0), atol=1e-9)


# --- O(N) closed forms against dense linear algebra ---------------------------------------

SIZES = [2, 3, 7, 50, 200]
#: Round-off allowance of the dense references: a 200 x 200 SVD / inverse is accurate to a few
#: hundred ulps of the largest entry.
DENSE_RTOL = 1e-11


def dense_phi(n: int, kind: str) -> np.ndarray:
    """``Phi`` entry by entry from its definition (independent of the implementation)."""
    out = np.zeros((n, n))
    for j in range(1, n):
        for k in range(j):
            out[j - 1, k] = 1.0 / j
        out[j - 1, j] = -1.0
        if kind == "orthonormal":
            out[j - 1] *= np.sqrt(j / (j + 1.0))
    out[n - 1] = 1.0 / n
    return out


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", SIZES)
def test_closed_form_singular_values_and_cond(kind, n):
    t = JacobiTransform(n, kind)
    phi = dense_phi(n, kind)
    assert_allclose(t.phi, phi, rtol=0, atol=1e-15)
    sv = np.linalg.svd(phi, compute_uv=False)
    assert_allclose(t.singular_values, sv, rtol=DENSE_RTOL)
    assert t.cond == pytest.approx(np.linalg.cond(phi), rel=DENSE_RTOL)
    # the advertised values: sqrt(2N) (paper) and sqrt(N) (orthonormal)
    assert t.cond == pytest.approx(np.sqrt(2 * n if kind == "paper" else n), rel=1e-14)
    # Phi Phi^T is diagonal with the squared row norms: the rows are orthogonal
    assert_allclose(phi @ phi.T, np.diag(t.singular_values_by_row**2), rtol=0, atol=1e-13)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", SIZES)
def test_linear_maps_match_dense_products(kind, n, rng):
    t = JacobiTransform(n, kind)
    phi = dense_phi(n, kind)
    inv = np.linalg.inv(phi)
    x = rng.normal(scale=30.0, size=(3, n, 2))
    scale = np.abs(x).max() * np.linalg.cond(phi)
    for got, mat in (
        (t.to_jacobi(x), phi),
        (t.to_positions(x), inv),
        (t.transpose(x), phi.T),
        (t.inverse_transpose(x), inv.T),
    ):
        assert_allclose(got, np.einsum("jk,mkd->mjd", mat, x), rtol=0, atol=DENSE_RTOL * scale)
    assert_allclose(t.phi_inv, inv, rtol=0, atol=DENSE_RTOL * np.abs(inv).max())
    assert_allclose(t.matrix_inv @ t.matrix, np.eye(2 * n), rtol=0, atol=1e-12)


def test_dense_matrices_refused_for_large_fleets():
    t = JacobiTransform(DENSE_MAX_N + 1)
    assert t.cond == pytest.approx(np.sqrt(2 * (DENSE_MAX_N + 1)), rel=1e-14)
    for name in ("phi", "phi_inv", "matrix", "matrix_inv"):
        with pytest.raises(FormationError, match="DENSE_MAX_N"):
            getattr(t, name)


def test_large_fleet_maps_are_linear_time():
    """100,000 vehicles: round trip and adjoint identity <Phi x, y> = <x, Phi^T y>, without a dense matrix."""
    n = 100_000
    rng = np.random.default_rng(5)
    for kind in KINDS:
        t = JacobiTransform(n, kind)
        x, y = rng.normal(size=(n, 2)), rng.normal(size=(n, 2))
        assert_allclose(t.to_positions(t.to_jacobi(x)), x, rtol=0, atol=1e-9)
        assert np.vdot(t.to_jacobi(x), y) == pytest.approx(np.vdot(x, t.transpose(y)), rel=1e-9)
        assert np.vdot(t.to_positions(x), y) == pytest.approx(np.vdot(x, t.inverse_transpose(y)), rel=1e-9)
        assert "phi" not in t.__dict__


def test_closest_pair_matches_brute_force(rng):
    for _ in range(20):
        n = int(rng.integers(2, 60))
        pts = rng.integers(-4, 5, size=(n, 2)).astype(float) * rng.uniform(0.5, 2.0)  # many ties and duplicates
        d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
        d[np.diag_indices(n)] = np.inf
        i, j, dist = closest_pair(pts)
        assert i < j and dist == pytest.approx(d.min(), abs=1e-12)
        assert np.linalg.norm(pts[i] - pts[j]) == pytest.approx(d.min(), abs=1e-12)
    with pytest.raises(FormationError, match="finite"):
        closest_pair([[0.0, 0.0], [np.nan, 1.0]])
