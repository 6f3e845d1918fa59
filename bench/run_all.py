"""Run every benchmark in bench/ and write bench/RESULTS.md (``make bench``).

Each ``bench_*.py`` runs in its own process (so one benchmark's memory and threads do not
disturb the next) and leaves a JSON fragment in ``bench/results/``; this script gathers
them with the machine (CPU model, cores), the library versions and the date.
"""

from __future__ import annotations

import datetime as dt
import importlib.metadata
import json
import os
import platform
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
LIBRARIES = ("mtmetrology", "numpy", "scipy", "numba", "scikit-spatial", "GTC", "suncal")


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def versions() -> list[str]:
    out = [f"Python {platform.python_version()}"]
    for name in LIBRARIES:
        try:
            out.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            pass
    return out


def markdown(fragments: list[dict]) -> str:
    lines = [
        "# Benchmark results",
        "",
        f"- date: {dt.datetime.now(dt.UTC).strftime('%Y-%m-%d %H:%M UTC')}",
        f"- machine: {cpu_model()}, {os.cpu_count()} logical cores, {platform.system()}",
        f"- versions: {', '.join(versions())}",
        "",
        "Min and median of at least 5 repeats. `vs ours` is the contender's median over ours "
        "(> 1: ours is faster); `/ floor` is the median over the first hardware floor listed, "
        "measured in the same run (writing the output once; drawing the random inputs is "
        "listed too).  The machine may be shared: compare ratios within one run.",
        "",
    ]
    for doc in fragments:
        timings = doc["timings"]
        ours = next((t for t in timings if t["kind"] == "ours"), None)
        floor = next((t for t in timings if t["kind"] == "floor"), None)
        lines += [
            f"## {doc['name']}",
            "",
            doc["problem"],
            "",
            "| contender | kind | min (s) | median (s) | vs ours | / floor |",
            "|---|---|---:|---:|---:|---:|",
        ]
        for t in timings:
            vs = f"{t['median'] / ours['median']:.2f}x" if ours and t is not ours else ""
            fl = f"{t['median'] / floor['median']:.2f}x" if floor and t["kind"] != "floor" else ""
            label = t["label"] + (f" ({t['note']})" if t.get("note") else "")
            lines.append(
                f"| {label} | {t['kind']} | {t['min']:.4f} | {t['median']:.4f} | {vs} | {fl} |"
            )
        for tg in doc["targets"]:
            unit = "x" if tg["relative_to"] else " s"
            ref = f" of {tg['relative_to']}" if tg["relative_to"] else ""
            state = "met" if tg["met"] else "**missed**"
            lines.append("")
            lines.append(
                f"Target: {tg['label']} ≤ {tg['limit']:g}{unit}{ref} — "
                f"{tg['value']:.3g}{unit}, {state}. {tg.get('text', '')}".rstrip()
            )
        for note in doc.get("notes", []):
            lines += ["", f"Note: {note}"]
        lines.append("")
    return "\n".join(lines)


def main() -> int:
    RESULTS.mkdir(exist_ok=True)
    for stale in RESULTS.glob("*.json"):
        stale.unlink()
    failed = []
    for script in sorted(HERE.glob("bench_*.py")):
        print(f"# {script.name}", flush=True)
        if subprocess.run([sys.executable, str(script)], cwd=HERE.parent).returncode != 0:
            failed.append(script.name)
    fragments = [json.loads(p.read_text()) for p in sorted(RESULTS.glob("*.json"))]
    (HERE / "RESULTS.md").write_text(markdown(fragments))
    print(f"wrote {HERE / 'RESULTS.md'} ({len(fragments)} benchmarks)")
    if failed:
        print(f"failed: {', '.join(failed)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
