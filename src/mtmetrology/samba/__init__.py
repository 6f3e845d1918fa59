"""SAMBA five-axis calibration (master balls + scale bar): set-ups and probing sequences."""

from mtmetrology.samba.setup import SambaSetup, probing_sequence

__all__ = ["SambaSetup", "probing_sequence"]
