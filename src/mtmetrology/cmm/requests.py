"""``mtm cmm calibrate`` as one library call: :func:`calibrate_ballplate_files`."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from mtmetrology.errors import InputError

if TYPE_CHECKING:  # loaded by the call: the command line's --help reads AUTO_CANDIDATES only
    from mtmetrology.cmm.calibrate import BallPlateCalibration
    from mtmetrology.kinematics.machine import Machine

__all__ = ["AUTO_CANDIDATES", "BallPlateRequest", "calibrate_ballplate_files"]

#: The models ``model="auto"`` compares by default.
AUTO_CANDIDATES = ("seed", "full-1", "full-2", "full-3")


@dataclass(frozen=True)
class BallPlateRequest:
    """A ball-plate calibration and, with ``model="auto"``, the model selection that chose
    its model (:func:`~mtmetrology.cmm.calibrate.cross_validate`).

    Attributes
    ----------
    calibration : BallPlateCalibration
    selection : dict or None
    """

    calibration: BallPlateCalibration
    selection: dict | None = None

    def to_dict(self) -> dict:
        """The ``ballplate-calibration`` document (with the model selection when made)."""
        return self.calibration.to_document(self.selection)


def calibrate_ballplate_files(
    records: str | Path,
    machine: str | Path | Machine,
    plate: str | Path,
    probes: str | Path,
    *,
    model: str = "seed",
    degrees: str | None = None,
    candidates=AUTO_CANDIDATES,
    sigma: float = 0.5e-3,
    seed: int = 0,
    adequacy: str = "scale",
    progress=None,
) -> BallPlateRequest:
    """Identify a CMM's error functions from ball-plate files (kinematic model).

    Parameters
    ----------
    records, plate, probes : path
        ``position,ball,probe,X,Y,Z`` records (mm), the plate certificate, the probe set.
    machine : Machine, preset name or machine YAML
    model : str
        ``seed``, ``full-<d>``, or ``auto``: the candidate with the lowest median
        held-out RMS over folds that hold out a block of balls in every plate position
        (:func:`~mtmetrology.cmm.calibrate.cross_validate`; the lowest AIC when no fair
        comparison is possible).
    degrees : str, optional
        Per-function degrees of a full model, e.g. ``E_YX=3,E_AZ=1``.
    candidates : sequence of str
        The models ``auto`` compares.
    sigma : float
        Standard deviation of a reading, mm (> 0).
    seed : int
        Seed of the U2/U3 sample points.
    adequacy : {"scale", "a-priori"}
        The identification engine's model-adequacy rule for the calibration
        (``"a-priori"``: ``--keep-a-priori-covariance``).
    progress : callable, optional
        ``progress(done, total)`` over the fits of ``auto``'s cross-validation.

    Returns
    -------
    BallPlateRequest
    """
    from mtmetrology.cmm.calibrate import calibrate_ballplate, cross_validate
    from mtmetrology.cmm.files import load_plate, load_probes, read_records
    from mtmetrology.cmm.models import parse_model
    from mtmetrology.kinematics.machine import Machine

    m = machine if isinstance(machine, Machine) else Machine.load(machine)
    pl, pr = load_plate(plate), load_probes(probes)
    rec = read_records(records, pl, pr)
    selection = None
    if model == "auto":
        if degrees:
            raise InputError("--degrees applies to a full-<d> model, not to --model auto")
        names = list(candidates)
        for c in names:
            parse_model(c)
        selection = cross_validate(m, rec, pl, pr, names, sigma=sigma, progress=progress)
        choice = parse_model(selection["chosen"])
    else:
        choice = parse_model(model, degrees)
    cal = calibrate_ballplate(
        m, rec, pl, pr, model=choice, sigma=sigma, seed=seed, adequacy=adequacy
    )
    return BallPlateRequest(cal, selection)
