"""Every ``float`` option of ``mtm`` refuses NaN and ±inf through one rule
(:func:`mtmetrology.cli._common.finite_number`, attached by ``MtmGroup``): exit 2, one line
on stderr naming the option, nothing written (issues 30 and 32)."""

from __future__ import annotations

import math

import pytest
import typer.main
from typer.testing import CliRunner

from mtmetrology.cli import build_app
from mtmetrology.errors import InputError


def _float_params(command, path=("mtm",)):
    for param in command.params:
        descriptor = getattr(param, "type_descriptor", None)
        if descriptor is not None and descriptor.annotation is float:
            yield " ".join(path), param
    for name, sub in getattr(command, "commands", {}).items():
        yield from _float_params(sub, (*path, name))


def test_every_float_option_of_every_command_refuses_nan_and_inf():
    params = list(_float_params(typer.main.get_command(build_app())))
    assert len(params) >= 70  # 76 when this was written: the walk reaches the commands
    for where, param in params:
        name = next(o for o in param.opts if o.startswith("--"))
        assert param.callback is not None, (where, name)
        assert param.callback(None, param, 2.5) == 2.5
        for bad in (math.nan, math.inf, -math.inf):
            with pytest.raises(InputError, match=f"^{name}: expected a finite number"):
                param.callback(None, param, bad)


def _runs(tmp_path):
    runs = tmp_path / "runs.csv"
    runs.write_text("value\n" + "\n".join(f"{10 + 1e-3 * (i % 3):.6f}" for i in range(20)))
    return runs


@pytest.mark.parametrize(
    ("option", "value"),
    [
        ("--calibrated", "nan"),
        ("--calibrated", "inf"),
        ("--calibrated", "-inf"),
        ("--u-cal", "nan"),
        ("--k", "inf"),
        ("--probe-u", "NaN"),
    ],
)
def test_budget_iso15530_refuses_a_non_finite_option(tmp_path, option, value):
    args = {"--calibrated": "10", "--u-cal": "0.5"} | {option: value}
    out = tmp_path / "b.json"
    result = CliRunner().invoke(
        build_app("budget"),
        ["budget", "iso15530-3", str(_runs(tmp_path)), *sum(args.items(), ()), "-o", str(out)],
    )
    lines = result.stderr.splitlines()
    assert (result.exit_code, len(lines), result.stdout) == (2, 1, "")
    assert lines[0].startswith(f"error: {option}: expected a finite number")
    assert not out.exists()


def test_history_trend_refuses_a_nan_mpe_before_opening_the_database(tmp_path):
    db = tmp_path / "h.sqlite"
    result = CliRunner().invoke(
        build_app("history"),
        ["history", "trend", "--db", str(db), "--machine", "m", "E_X0C", "--mpe", "nan"],
    )
    assert result.exit_code == 2
    assert result.stderr.splitlines() == ["error: --mpe: expected a finite number, got nan"]
    assert not db.exists()
