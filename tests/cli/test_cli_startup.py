"""Start-up of the command line, in fresh interpreters: what each command line loads.

``mtm --help`` lists the commands from their summaries and imports no command module
and no engine; ``mtm machine list`` reads the preset registry and builds no machine (no
numpy, no kinematics config); no command's ``--help`` loads numpy, a file schema, the
report layer (matplotlib, Jinja2) or scikit-learn.  Times are in bench/bench_startup.py
(never asserted here).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
import typer

from mtmetrology.cli import ALIASES, SUMMARIES, build_app

#: Runs ``mtm`` as its console script does, then prints the loaded modules as JSON.
PROBE = (
    "import atexit, json, sys\n"
    "atexit.register(lambda: sys.__stderr__.write('MODULES ' + json.dumps(sorted(sys.modules))))\n"
    "from mtmetrology.__main__ import main\n"
    "main()\n"
)
#: Subcommand lines whose help shows a constant of the library (criteria, default duration,
#: fewest targets per coefficient): read from light modules, not from the numpy ones.
SUBCOMMAND_HELP = [
    ["samba", "plan", "--help"],
    ["repeatability", "fit", "--help"],
    ["export", "siemens", "--help"],
    ["export", "check", "--help"],
]
LINES = (
    [["--help"], ["machine", "list"]]
    + [[c, "--help"] for c in [*SUMMARIES, *ALIASES]]
    + SUBCOMMAND_HELP
)


@pytest.fixture(scope="module")
def loaded() -> dict[str, set[str]]:
    """The modules each command line loads, from fresh interpreters started together."""
    runs = {
        " ".join(args): subprocess.Popen(
            [sys.executable, "-c", PROBE, *args],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        for args in LINES
    }
    out = {}
    for line, run in runs.items():
        _, err = run.communicate(timeout=300)
        assert run.returncode == 0, err
        out[line] = set(json.loads(err.rpartition("MODULES ")[2]))
    return out


def _top(modules: set[str]) -> set[str]:
    return {m.split(".")[0] for m in modules}


def test_listing_loads_no_command_and_no_engine(loaded):
    ours = {m for m in loaded["--help"] if m.startswith("mtmetrology")}
    assert ours == {
        "mtmetrology",
        "mtmetrology.__main__",
        "mtmetrology._lazy",
        "mtmetrology._memory",
        "mtmetrology.cli",
        "mtmetrology.cli._common",
        "mtmetrology.errors",
        "mtmetrology.io",
        "mtmetrology.io.files",
    }
    assert not _top(loaded["--help"]) & {"scipy", "pyarrow", "pydantic", "yaml"}


def test_machine_list_reads_the_preset_registry_only(loaded):
    """The listing reads the preset files: no machine is built (no chain, no numpy, no
    kinematics config), nothing of the other engines or the applications."""
    modules = loaded["machine list"]
    assert "mtmetrology.kinematics.preset_registry" in modules
    assert not modules & {
        "mtmetrology.kinematics.machine",
        "mtmetrology.kinematics.chain",
        "mtmetrology.kinematics.config",
    }
    layers = {".".join(m.split(".")[:2]) for m in modules if m.startswith("mtmetrology.")}
    assert not layers & {
        "mtmetrology.identification",
        "mtmetrology.uncertainty",
        "mtmetrology.fitting",
        "mtmetrology.samba",
        "mtmetrology.report",
    }
    assert not _top(modules) & {"numpy", "scipy", "pyarrow", "sklearn", "matplotlib"}


@pytest.mark.parametrize("line", [" ".join(a) for a in LINES])
def test_no_help_loads_the_report_layer_or_scikit_learn(loaded, line):
    assert not _top(loaded[line]) & {"matplotlib", "jinja2", "sklearn"}
    assert "mtmetrology.report" not in loaded[line]


@pytest.mark.parametrize("line", [" ".join(a) for a in LINES])
def test_no_help_loads_an_engine_it_does_not_run(loaded, line):
    """No command line loads numpy, scipy, pyarrow, scikit-learn or SQLAlchemy to show its
    help, nor a file schema; pydantic comes with Typer (its parameter adapters)."""
    modules = loaded[line]
    assert not _top(modules) & {"numpy", "scipy", "pyarrow", "sklearn", "sqlalchemy", "alembic"}
    assert not modules & {"mtmetrology.kinematics.config", "mtmetrology.io.schema"}


def test_predict_loads_neither_the_fitting_nor_the_uncertainty_engine(loaded):
    layers = {".".join(m.split(".")[:2]) for m in loaded["predict --help"]}
    assert not layers & {"mtmetrology.fitting", "mtmetrology.uncertainty"}


def test_summaries_are_the_first_paragraph_of_each_command_help():
    full = typer.main.get_command(build_app())
    for name in SUMMARIES:
        assert full.commands[name].help.split("\n\n")[0].strip() == SUMMARIES[name], name


def test_the_listing_shows_what_the_full_command_line_shows():
    def listing(application) -> str:
        command = typer.main.get_command(application)
        with command.make_context("mtm", ["--help"], resilient_parsing=True) as ctx:
            return command.get_help(ctx)

    assert listing(build_app(listing=True)) == listing(build_app())
