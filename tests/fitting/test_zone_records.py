"""Zone results as records: the bounds of an exact parallel zone and the text of the
probe-radius refusal (the iteration count of an iterative zone: test_minimax.py)."""

import numpy as np
import pytest

from mtmetrology.fitting.elements import Sphere
from mtmetrology.fitting.minimum_zone import straightness
from mtmetrology.fitting.probe import compensate
from mtmetrology.fitting.validation import FitError


def test_a_parallel_zone_is_centred_on_the_mid_line():
    # residuals y − s·x of (0,0), (1,1), (2,0), (3,1) span 1 + |s| (s > 0) or 1 − 3s
    # (s < 0): the narrowest zone is horizontal, 1 mm wide, every point on a boundary
    zone = straightness([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0], [3.0, 1.0]])
    assert zone.form_error == pytest.approx(1.0, abs=1e-12)
    assert zone.bounds == pytest.approx((-0.5, 0.5), abs=1e-12)
    assert (zone.iterations, zone.converged) == (0, True)
    np.testing.assert_array_equal(zone.contacts, [0, 1, 2, 3])


def test_a_tip_larger_than_the_fitted_sphere_is_refused():
    with pytest.raises(FitError) as err:
        compensate(Sphere([0.0, 0.0, 0.0], 2.0), 3.0)
    assert str(err.value) == (
        "tip radius 3.0 mm is not smaller than the fitted radius 2.000000 mm of the "
        "stylus-centre sphere"
    )
