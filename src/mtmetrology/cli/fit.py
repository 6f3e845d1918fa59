"""``mtm fit``: geometric elements from point sets."""


def fit() -> None:
    """Fit a geometric element to points (under construction)."""
    raise SystemExit("mtm fit is not available yet")
