"""Mutation testing of the engines' core modules, one module group at a time (mutmut 3).

Each group is mutated in its own work directory (``build/mutation/<group>/``) holding a
copy of ``src/``, ``tests/`` and ``examples/`` and a ``pyproject.toml`` whose
``[tool.mutmut]`` section names the group's files and the test files that exercise
them, so a run stays within minutes: mutmut forks each mutant from a warmed-up pytest
process and runs only the selected tests that reach the mutated function.

Usage::

    python tools/mutation.py                     # every group
    python tools/mutation.py units optimize      # some groups
    python tools/mutation.py fitting --sample 300 --seed 1
    python tools/mutation.py --list

``--sample N`` runs a uniform random sample of N of the group's mutants and reports the
killed fraction with its 95 % Wilson interval: an estimate of the score for groups too
large to run whole on a shared machine.  Scores count a timeout as killed (the mutant
made the tests hang) and a mutant no selected test reaches as survived.  Tests marked
``slow`` (statistical coverage checks) are left out of mutation runs to keep them short.
Results go to ``build/mutation/<group>/scores.json``; ``tests/MUTATION.md`` records them.
"""

from __future__ import annotations

import argparse
import json
import math
import random
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PKG = "src/mtmetrology"

#: group -> (files to mutate, test paths that exercise them)
#: (``fitting`` leaves out ``fitting/batch.py``: see EXCLUDED)
GROUPS: dict[str, tuple[list[str], list[str]]] = {
    "units": ([f"{PKG}/units.py"], ["tests/test_units.py"]),
    "rng": ([f"{PKG}/rng.py"], ["tests/test_rng.py"]),
    "optimize": (
        [f"{PKG}/optimize.py"],
        ["tests/test_optimize.py", "tests/test_optimize_contract.py"],
    ),
    "kinematics": (
        [
            f"{PKG}/kinematics/{name}.py"
            for name in (
                "basis",
                "config",
                "conventions",
                "machine",
                "parameter_set",
                "parameters",
                "topology",
            )
        ],
        ["tests/kinematics"],
    ),
    "kinematics-chain": (
        [f"{PKG}/kinematics/chain.py", f"{PKG}/kinematics/_sparse3.py"],
        ["tests/kinematics"],
    ),
    "identification": ([f"{PKG}/identification/*"], ["tests/identification"]),
    # every fitting module but the batched fits (their own group)
    "fitting": ([f"{PKG}/fitting/*"], ["tests/fitting"]),
    "fitting-batch": ([f"{PKG}/fitting/batch.py"], ["tests/fitting/test_batch.py"]),
    "uncertainty": ([f"{PKG}/uncertainty/*"], ["tests/uncertainty"]),
}

#: files of a group's glob that belong to another group
EXCLUDED = {"fitting": [f"{PKG}/fitting/batch.py"]}

KILLED = {1, 3}
TIMEOUT = {36, -24, 24, 152, 255}
NOT_RUN = {None, 2, 34, 37}  # not checked, interrupted, skipped, caught by type check


def _toml_list(values: list[str]) -> str:
    return "[" + ", ".join(json.dumps(v) for v in values) + "]"


def prepare(group: str, tree: Path = ROOT) -> Path:
    """A fresh work directory with the sources, tests and the group's mutmut config."""
    files, tests = GROUPS[group]
    work = ROOT / "build" / "mutation" / (group if tree == ROOT else f"{group}@{tree.name}")
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    for name in ("src", "tests", "examples"):
        shutil.copytree(
            tree / name, work / name, ignore=shutil.ignore_patterns("__pycache__", "*.pyc")
        )
    pytest_options = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["pytest"][
        "ini_options"
    ]
    markers = _toml_list(pytest_options.get("markers", []))
    (work / "pyproject.toml").write_text(
        "[tool.pytest.ini_options]\n"
        'addopts = "-ra --strict-markers"\n'
        f"markers = {markers}\n\n"
        "[tool.mutmut]\n"
        'source_paths = ["src"]\n'
        f"only_mutate = {_toml_list(files)}\n"
        f"do_not_mutate = {_toml_list(EXCLUDED.get(group, []))}\n"
        "pytest_add_cli_args = "
        '["-p", "no:xdist", "-p", "no:cacheprovider", "--hypothesis-seed=0", "-m", "not slow"]\n'
        f"pytest_add_cli_args_test_selection = {_toml_list(tests)}\n"
        'also_copy = ["examples/"]\n'
    )
    return work


def _mutmut(work: Path, names: list[str], max_children: int, *, check: bool = True) -> None:
    command = [sys.executable, "-m", "mutmut", "run", "--max-children", str(max_children)]
    with open(work / "mutmut.log", "a") as log:
        done = subprocess.run([*command, *names], cwd=work, stdout=log, stderr=subprocess.STDOUT)
    if check and done.returncode != 0:
        raise SystemExit(f"mutmut failed in {work}; see {work / 'mutmut.log'}")


def exit_codes(work: Path) -> dict[str, int | None]:
    codes: dict[str, int | None] = {}
    for meta in sorted((work / "mutants").rglob("*.meta")):
        codes.update(json.loads(meta.read_text())["exit_code_by_key"])
    return codes


def wilson(killed: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial proportion."""
    if n == 0:
        return (0.0, 1.0)
    p = killed / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (centre - half, centre + half)


def score(codes: dict[str, int | None], names: list[str] | None) -> dict:
    keys = names if names is not None else list(codes)
    run = [k for k in keys if codes.get(k) not in NOT_RUN]
    killed = sum(codes[k] in KILLED or codes[k] in TIMEOUT for k in run)
    survived = sorted(k for k in run if not (codes[k] in KILLED or codes[k] in TIMEOUT))
    low, high = wilson(killed, len(run))
    return {
        "mutants": len(codes),
        "run": len(run),
        "killed": killed,
        "score": killed / len(run) if run else float("nan"),
        "interval_95": [low, high],
        "sampled": names is not None,
        "survived": survived,
    }


def run_group(
    group: str, sample: int | None, seed: int, max_children: int, tree: Path, rerun: bool = False
) -> dict:
    if rerun:
        return rerun_survivors(group, max_children, tree)
    work = prepare(group, tree)
    if sample is None:
        _mutmut(work, [], max_children)
        result = score(exit_codes(work), None)
    else:
        # generate the mutants and collect the test statistics without running any (mutmut
        # then stops on the empty selection, which is expected here)
        _mutmut(work, ["__nothing__"], max_children, check=False)
        names = sorted(exit_codes(work))
        if not names:
            raise SystemExit(f"no mutants generated in {work}; see {work / 'mutmut.log'}")
        chosen = sorted(random.Random(seed).sample(names, min(sample, len(names))))
        _mutmut(work, chosen, max_children)
        result = score(exit_codes(work), chosen)
    (work / "scores.json").write_text(json.dumps(result, indent=1))
    return result


def rerun_survivors(group: str, max_children: int, tree: Path) -> dict:
    """Run only the survivors of the group's last run against today's tests.

    Tests are only ever added, and the source must be unchanged (checked against the
    mutant names), so a mutant killed before stays killed: the new score is the old kills
    plus the new ones over the same mutants.
    """
    work = ROOT / "build" / "mutation" / group
    previous = json.loads((work / "scores.json").read_text())
    survivors = previous["survived"]
    prepare(group, tree)
    _mutmut(work, ["__nothing__"], max_children, check=False)
    known = set(exit_codes(work))
    if not set(survivors) <= known:
        raise SystemExit(f"{group}: the sources changed since the last run; run it whole")
    _mutmut(work, survivors, max_children)
    codes = exit_codes(work)
    still = sorted(k for k in survivors if not (codes[k] in KILLED or codes[k] in TIMEOUT))
    killed = previous["killed"] + len(survivors) - len(still)
    low, high = wilson(killed, previous["run"])
    result = {
        **previous,
        "killed": killed,
        "score": killed / previous["run"],
        "interval_95": [low, high],
        "survived": still,
    }
    (work / "scores.json").write_text(json.dumps(result, indent=1))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("groups", nargs="*", help=f"groups (default all): {', '.join(GROUPS)}")
    parser.add_argument("--sample", type=int, help="run a random sample of N mutants per group")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample")
    parser.add_argument("--max-children", type=int, default=2)
    parser.add_argument("--list", action="store_true", help="list the groups and exit")
    parser.add_argument(
        "--rerun-survivors",
        action="store_true",
        help="re-test only the survivors of the group's last run (after adding tests)",
    )
    parser.add_argument(
        "--tree",
        type=Path,
        default=ROOT,
        help="take src/, tests/, examples/ from this tree (e.g. an export of an older commit)",
    )
    args = parser.parse_args(argv)
    if args.list:
        for name, (files, tests) in GROUPS.items():
            print(f"{name}: {' '.join(files)}  <-  {' '.join(tests)}")
        return 0
    unknown = [g for g in args.groups if g not in GROUPS]
    if unknown:
        parser.error(f"unknown group(s) {', '.join(unknown)}; --list shows them")
    for group in args.groups or list(GROUPS):
        r = run_group(
            group,
            args.sample,
            args.seed,
            args.max_children,
            args.tree.resolve(),
            args.rerun_survivors,
        )
        low, high = r["interval_95"]
        kind = f"sample of {r['run']}" if r["sampled"] else f"all {r['run']}"
        print(
            f"{group}: {r['killed']}/{r['run']} killed = {100 * r['score']:.1f} % "
            f"({kind} of {r['mutants']} mutants; 95 % interval {100 * low:.1f}-{100 * high:.1f} %)"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
