"""Error-motion bases against numpy.polynomial, derivatives against differences."""

import numpy as np
import pytest
from numpy.polynomial import chebyshev, legendre

from mtmetrology.kinematics.basis import Basis


@pytest.mark.parametrize(
    ("kind", "vander"), [("legendre", legendre.legvander), ("chebyshev", chebyshev.chebvander)]
)
def test_orthogonal_bases_match_numpy(kind, vander):
    b = Basis(kind, centre=5.0, half_range=225.0)
    q = np.linspace(-220.0, 230.0, 41)
    phi, _ = b.values(q, 5)
    np.testing.assert_allclose(phi.T, vander((q - 5.0) / 225.0, 5), atol=1e-14)


def test_monomial_is_powers_of_the_raw_position():
    phi, dphi = Basis("monomial").values(np.array([2.0, -3.0]), 3)
    np.testing.assert_allclose(phi[:, 1], [1.0, -3.0, 9.0, -27.0])
    np.testing.assert_allclose(dphi[:, 1], [0.0, 1.0, -6.0, 27.0])


@pytest.mark.parametrize("kind", ["monomial", "legendre", "chebyshev"])
def test_derivatives_match_central_differences(kind):
    b = Basis(kind, 0.3, 1.7) if kind != "monomial" else Basis(kind)
    q = np.linspace(-1.2, 1.5, 13)
    h = 1e-6
    _, dphi = b.values(q, 6)
    fd = (b.values(q + h, 6)[0] - b.values(q - h, 6)[0]) / (2 * h)
    np.testing.assert_allclose(dphi, fd, rtol=1e-7, atol=1e-7)


def test_bad_basis():
    with pytest.raises(ValueError, match="unknown basis"):
        Basis("fourier")
    with pytest.raises(ValueError, match="half_range"):
        Basis("legendre", 0.0, 0.0)
