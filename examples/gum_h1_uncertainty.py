"""GUM H.1, the end-gauge calibration, by the GUF and by adaptive Monte Carlo, validated.

The measurement model of JCGM 100:2008, annex H.1, as a model file: the GUF gives
u = 32 nm and U_99 = 93 nm as the annex; the adaptive Monte Carlo method of JCGM 101:2008
gives u = 34 nm, as the annex's second-order analysis (H.1.7), and a shorter 99 %
interval, so the GUF is not validated at two significant digits (JCGM 101, §8). What
``mtm uncertainty run --method both --adaptive`` computes (its command is printed).
``gum_h1_end_gauge.py`` prints the same case as a certificate. Run it on its own::

    python examples/gum_h1_uncertainty.py [OUT]

References
----------
JCGM 100:2008 (GUM), annex H.1; JCGM 101:2008, §7.9 and §8.
"""

from __future__ import annotations

from pathlib import Path

from mtmetrology.formatting import format_uncertainty
from mtmetrology.report.demo import DemoContext
from mtmetrology.report.results import add_result
from mtmetrology.uncertainty.evaluation import evaluate_model
from mtmetrology.uncertainty.modelfile import load_model

#: The model file of GUM H.1 shipped beside this script (also read by gum_h1_end_gauge.py).
MODEL = Path(__file__).with_name("gum-h1-end-gauge.yaml")


def main(ctx: DemoContext) -> None:
    ctx.rule("GUM H.1: GUF and Monte Carlo")
    ctx.write_text(MODEL.read_text(encoding="utf-8"), "uncertainty", "gum-h1.yaml")
    loaded = load_model(ctx.path("uncertainty", "gum-h1.yaml"))
    with ctx.step("GUM H.1 by GUF and adaptive Monte Carlo (2 significant digits)"):
        evaluation = evaluate_model(
            loaded,
            "both",
            adaptive=True,
            digits=2,
            seed=ctx.seed,
            p=0.99,
            source=str(ctx.path("uncertainty", "gum-h1.yaml")),
        )
    g, r, validation = evaluation.guf, evaluation.mcm, evaluation.validation
    ctx.write_json(evaluation.to_dict(), "uncertainty", "gum-h1-result.json")
    ctx.report.section(
        "Uncertainty of a measurement model: GUM H.1",
        "The end-gauge calibration of JCGM 100:2008, annex H.1: the GUF gives u = 32 nm and "
        "U_99 = 93 nm as the annex; the adaptive Monte Carlo method of JCGM 101:2008 gives "
        "u = 34 nm, as the annex's second-order analysis (H.1.7), and a shorter 99 % "
        "interval, so the GUF is not validated at two significant digits.",
    )
    add_result(ctx.report, evaluation)
    ctx.command(
        "GUF, Monte Carlo and validation",
        "uncertainty",
        "run",
        ctx.shown("uncertainty", "gum-h1.yaml"),
        "--method",
        "both",
        "--adaptive",
        "--seed",
        str(ctx.seed),
        "--p",
        "0.99",
    )
    ctx.summary.append(
        f"GUM H.1: GUF u = {format_uncertainty(g.standard_uncertainty[0])} nm, Monte Carlo "
        f"u = {format_uncertainty(r.standard_uncertainty[0])} nm ({r.trials} trials), GUF "
        f"{'validated' if validation.passed else 'not validated'} at p = 0.99"
    )


if __name__ == "__main__":
    from mtmetrology.report.demo import run_example

    run_example(main, "gum_h1_uncertainty")
