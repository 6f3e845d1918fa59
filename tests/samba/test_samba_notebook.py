"""SAMBA results show themselves in Jupyter as their report fragment."""

from __future__ import annotations

import re

import numpy as np

from mtmetrology.samba.verify import LengthCheck


def test_length_check_repr_html_shows_the_errors_per_pair():
    # exact: lengths 100.010 and 99.980 mm against L = 100 mm are errors of 10 and -20 µm
    check = LengthCheck(
        pairs=("p1", "p2"),
        length=100.0,
        u_length=None,
        tip_radius=3.0,
        nominal=np.array([100.010, 99.980]),
        compensated=np.array([100.0005, 99.9995]),
    )
    html = check._repr_html_()
    assert len(re.findall(r'<figure class="mtm-figure"', html)) == 1
    rows = re.findall(r"<tr><td>(p\d)</td><td[^>]*>(.*?)</td><td[^>]*>(.*?)</td></tr>", html)
    assert [(p, float(a), float(b)) for p, a, b in rows] == [
        ("p1", 10.0, 0.5),
        ("p2", -20.0, -0.5),
    ]
