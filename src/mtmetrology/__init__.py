"""mtmetrology: machine-tool and CMM metrology.

Kinematic error models of any serial machine, identification of those errors from
artefact measurements, GUM / Monte Carlo uncertainty, and geometric elements.
Internal units are mm, rad and dimensionless; see :mod:`mtmetrology.units`.
"""

__version__ = "0.1.0"
