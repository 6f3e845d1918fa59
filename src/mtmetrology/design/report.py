"""What a report shows for a SAMBA calibration plan (registered with ``@renders``).

:class:`~mtmetrology.design.samba.SambaDesign`: the chosen balls, the programme summary
(indexations, measurements, estimated duration T ≈ a·M_T + b·indexations), the rank,
condition number and observability indices O1–O5 of the column-scaled identification
Jacobian, the predicted standard uncertainty of every parameter for the planned probing
noise, and the criterion of every DETMAX run against its exchanges.

References
----------
Alami Mchichi, N. (2018). *Étalonnage des machines-outils à cinq axes : configuration
optimisée des artefacts et de la séquence de mesure de la méthode SAMBA en vue d'une
estimation efficace des erreurs géométriques*. PhD thesis, École Polytechnique de
Montréal. Ch. 5 (DETMAX, eq. 5.14, §5.10 test duration), Annex A.

Mitchell, T. J. (1974). An algorithm for the construction of "D-optimal" experimental
designs. *Technometrics* 16(2), 203–210.
"""

from __future__ import annotations

from mtmetrology.design.counts import MINUTES_PER_MEASUREMENT
from mtmetrology.design.samba import SambaDesign
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.report.results import renders

__all__: list[str] = []


@renders(SambaDesign, "SAMBA calibration plan")
def _samba_design(
    rep: Report,
    design,
    *,
    minutes_per_measurement: float = MINUTES_PER_MEASUREMENT,
    minutes_per_indexation: float = 0.0,
    **_,
) -> None:
    doc = design.to_dict(minutes_per_measurement, minutes_per_indexation)
    bar = doc["scale_bar"]
    rep.section(
        "Artefact",
        f"{len(doc['balls'])} master ball(s) and a scale bar of {bar['length_mm']:.4f} mm "
        f"(u = {bar['u_mm']:g} mm), workpiece (C-table) frame.",
    )
    rows = [[b["id"], *b["centre_mm"], b["stem_mm"]] for b in doc["balls"]]
    rows += [
        [end, *centre, None] for end, centre in zip(bar["ends"], bar["centres_mm"], strict=True)
    ]
    rep.table(["ball", "x mm", "y mm", "z mm", "stem mm"], rows)

    rep.section(
        "Programme",
        "Duration T ≈ a·M_T + b·indexations (Alami Mchichi 2018, §5.10), "
        "M_T the number of ball measurements.",
    )
    rep.table(
        ["item", "value"],
        [
            ["machine", doc["machine"]],
            ["error model", doc["model"]],
            ["criterion", doc["criterion"]],
            ["k (strategy xB.kn)", doc["k"]],
            ["count rule", f"{doc['count_rule']} ({doc['count_rule_reason']})"],
            ["indexations chosen", doc["n_indexations"]],
            ["accessible candidate indexations", doc["n_accessible_indexations"]],
            ["candidate indexations", doc["n_candidate_indexations"]],
            ["ball measurements M_T", doc["n_measurements"]],
            ["a, min per measurement", doc["minutes_per_measurement"]],
            ["b, min per indexation", doc["minutes_per_indexation"]],
            ["estimated duration, h", doc["duration_h"]],
        ],
    )

    rep.section("Identifiability of the plan")
    rows = [
        ["unknowns", doc["n_unknowns"]],
        ["rank", doc["rank"]],
        ["condition number (columns scaled)", doc["condition_scaled"]],
        ["condition number (internal units)", doc["condition_raw"]],
    ]
    rows += [[f"observability {k}", v] for k, v in doc["observability"].items()]
    rep.table(["quantity", "value"], rows)

    rep.section(
        "Predicted standard uncertainties",
        f"u = sqrt(diag((JᵀWJ)⁻¹)) for a probing noise of {doc['probing_sigma_um']:g} µm "
        "per coordinate and the scale bar's u; UPF = u per µm of probing noise.",
    )
    rep.table(
        ["parameter", "u", "unit", "UPF", "UPF unit"],
        [[p["name"], p["u"], p["unit"], p["upf"], p["upf_unit"]] for p in doc["parameters"]],
    )

    searches = [("step 1: balls", design.balls_search)]
    searches.append(("step 2: indexations", design.indexations_search))
    rep.section("DETMAX convergence", "The criterion never decreases along a run.")
    for name, search in searches:
        if search is None:
            continue
        runs = search.runs
        rep.figure(
            figures.convergence(
                [r.history for r in runs],
                labels=[f"start {i + 1}" for i in range(len(runs))],
                ylabel=search.criterion,
                title=name,
            ),
            caption=f"{name}: best {search.best.value:.6g} after {search.best.exchanges} "
            f"exchanges ({search.best.message}).",
        )
