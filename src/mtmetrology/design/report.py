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

from mtmetrology.design.compare import StrategyComparison
from mtmetrology.design.counts import MINUTES_PER_MEASUREMENT
from mtmetrology.design.samba import SambaDesign
from mtmetrology.formatting import format_uncertainty
from mtmetrology.report import figures
from mtmetrology.report.document import Report
from mtmetrology.report.results import renders

__all__ = ["add_convergence"]


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
        f"{_count(len(doc['balls']), 'master ball')} and a scale bar of {bar['length_mm']:.4f} mm "
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
            ["a, min per measurement", f"{doc['minutes_per_measurement']:.4g}"],
            ["b, min per indexation", f"{doc['minutes_per_indexation']:.4g}"],
            ["estimated duration, h", f"{doc['duration_h']:.1f}"],
        ],
    )

    rep.section("Identifiability of the plan")
    rows = [
        ["unknowns", doc["n_unknowns"]],
        ["rank", doc["rank"]],
        ["condition number (columns scaled)", f"{doc['condition_scaled']:.4g}"],
        ["condition number (internal units)", f"{doc['condition_raw']:.4g}"],
    ]
    rows += [[f"observability {k}", f"{v:.4g}"] for k, v in doc["observability"].items()]
    rep.table(["quantity", "value"], rows)

    rep.section(
        "Predicted standard uncertainties",
        f"u = sqrt(diag((JᵀWJ)⁻¹)) for a probing noise of {doc['probing_sigma_um']:g} µm "
        "per coordinate and the scale bar's u; UPF = u/σ, that u over σ in µm (the scale "
        "bar's u included: for a scale parameter the bar dominates).",
    )
    rep.table(
        ["parameter", "u", "unit", "UPF", "UPF unit"],
        [
            [p["name"], format_uncertainty(p["u"]), p["unit"], format_uncertainty(upf), unit]
            for p in doc["parameters"]
            for upf, unit in [(p["upf"], p["upf_unit"])]
        ],
        caption="Uncertainties with two significant digits (JCGM 100:2008, 7.2.6); the plan "
        "file keeps full precision.",
    )

    gain = doc["stylus_gain"]
    if gain is not None:
        _stylus_gain(rep, doc, gain)

    rep.section("DETMAX convergence", "The criterion never decreases along a run.")
    for name, search in (
        ("step 1: balls", design.balls_search),
        ("step 2: indexations", design.indexations_search),
    ):
        if search is not None:
            add_convergence(rep, name, search)


def _stylus_gain(rep: Report, doc: dict, gain: dict) -> None:
    """What the styli after the first buy: rank, condition and u, one stylus against all."""
    first = doc["tools"][0]["id"]
    one, every = gain["one_stylus"], gain["all_styli"]
    rep.section(
        "What the second stylus buys",
        f"The same balls and indexations probed with stylus {first} alone, against every "
        f"stylus ({', '.join(t['id'] for t in doc['tools'])}); each stylus has its own "
        "three tool unknowns (Alami Mchichi (2018) Table 4.4). Resolved: "
        f"{', '.join(gain['resolved']) or 'none'}.",
    )

    def cond(d):
        return (
            "∞ (rank deficient)"
            if d["condition_scaled"] is None
            else f"{d['condition_scaled']:.4g}"
        )

    rep.table(
        ["quantity", f"{first} alone", "all styli"],
        [
            ["unknowns", one["n_unknowns"], every["n_unknowns"]],
            ["rank", one["rank"], every["rank"]],
            ["condition number (columns scaled)", cond(one), cond(every)],
            [
                "confounded",
                "; ".join(" ~ ".join(g) for g in one["confounded"]) or "none",
                "; ".join(" ~ ".join(g) for g in every["confounded"]) or "none",
            ],
        ],
    )
    rep.table(
        ["parameter", f"u, {first} alone", "u, all styli", "unit"],
        [
            [
                q["name"],
                "not identifiable" if q["u_one"] is None else format_uncertainty(q["u_one"]),
                "not identifiable" if q["u_all"] is None else format_uncertainty(q["u_all"]),
                q["unit"],
            ]
            for q in gain["parameters"]
        ],
        caption="Predicted standard uncertainties for the planned probing noise; with one "
        "stylus a rank-deficient problem has no u for any parameter.",
    )


_WORDS = "no one two three four five six seven eight nine ten eleven twelve".split()


def _count(n: int, noun: str) -> str:
    """``n`` ``noun`` in words: "one master ball", "two master balls", "13 exchanges"."""
    number = _WORDS[n] if 0 <= n < len(_WORDS) else str(n)
    return f"{number} {noun}" + ("" if n == 1 else "s")


def add_convergence(rep: Report, name: str, search) -> None:
    """The criterion of every DETMAX run against its exchanges, or why there is no curve.

    A run whose random start is already a local optimum (the first candidate added is the
    one removed) makes no exchange: its history is one value, and a figure of single
    points would show nothing, so the section says so in words.
    """
    runs = search.runs
    best = search.best
    caption = (
        f"{name}: best {best.value:.6g} after {_count(best.exchanges, 'exchange')} "
        f"({best.message})."
    )
    if all(r.exchanges == 0 for r in runs):
        starts = "the random start was" if len(runs) == 1 else f"each of the {len(runs)} starts was"
        rep.text(
            f"{caption} No curve to draw: {starts} already a local optimum of DETMAX (the first "
            "candidate added was the one removed), so the criterion has a single value."
        )
        return
    rep.figure(
        figures.convergence(
            [r.history for r in runs],
            labels=[f"start {i + 1}" for i in range(len(runs))],
            ylabel=search.criterion,
            title=name,
        ),
        caption=caption,
    )


@renders(StrategyComparison, "SAMBA strategy comparison")
def _strategy_comparison(rep: Report, comparison, **_) -> None:
    """The sweep's table (Tables 5.3 and 5.5 of the source), the figure, mean UPF per unit."""
    rep.section(
        f"SAMBA strategy comparison, {comparison.model}-parameter model",
        f"{len(comparison.strategies)} strategies on {comparison.n_candidates} candidate "
        f"indexations, probing σ = {comparison.sigma_um:g} µm; condition numbers of the "
        "column-scaled Jacobian (Cond_N: every candidate; start/end: DETMAX's random start "
        f"and result); gauge block of {comparison.gauge_length_mm:g} mm simulated (module "
        "notes of mtmetrology.design.compare).",
    )
    header, rows = comparison.table()
    rep.table(header, rows)
    rep.figure(comparison.figure(), caption="Condition number against test duration.")
    units = sorted({u for s in comparison.strategies for u in s.mean_upf})
    rep.table(
        ["strategy", *[f"mean UPF ({u})" for u in units]],
        [
            [s.name, *[format_uncertainty(s.mean_upf[u]) for u in units]]
            for s in comparison.strategies
        ],
        caption="Mean UPF per unit group (eq. 5.19 over parameters of one unit only).",
    )
