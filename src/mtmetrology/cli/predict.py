"""``mtm predict``: compensated workpiece coordinates from axis readings."""


def predict() -> None:
    """Predict compensated coordinates (under construction)."""
    raise SystemExit("mtm predict is not available yet")
