"""mtm samba compare-plans: the comparison JSON reads back as the library's result, the report
is written, and bad input is refused with one line, exit 2, nothing written."""

import json

from typer.testing import CliRunner

from mtmetrology.cli import app
from mtmetrology.design.compare import StrategyComparison
from mtmetrology.design.counts import indexation_count

runner = CliRunner()
BALLS = """kind: samba-balls
balls:
  - {id: "1", centre_mm: [-80, -40, 100]}
  - {id: "2", centre_mm: [80, -40, 150]}
"""
PAIRS = "B,C\n" + "".join(f"{b},{c}\n" for b in range(-90, 91, 30) for c in range(0, 360, 45))
BASE = ["samba", "compare-plans", "--machine", "five-axis-wcbxfzyst", "--model", "13"]


def test_compare_writes_the_result_and_the_report(tmp_path):
    (tmp_path / "balls.yaml").write_text(BALLS)
    (tmp_path / "pairs.csv").write_text(PAIRS)
    out, rep = tmp_path / "cmp.json", tmp_path / "cmp.html"
    args = [
        *BASE, "--balls", str(tmp_path / "balls.yaml"), "--indexations",
        str(tmp_path / "pairs.csv"), "--n-balls", "1,2", "--k", "3", "--starts", "1",
        "--seed", "5", "-o", str(out), "--report", str(rep), "--json",
    ]  # fmt: skip
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    doc = json.loads(out.read_text())
    assert json.loads(result.stdout) == doc
    res = StrategyComparison.from_dict(doc)
    assert [s.name for s in res.strategies] == ["1B.3n O2", "2B.3n O2"]
    assert [s.n_indexations for s in res.strategies] == [indexation_count(3, 13, n) for n in (1, 2)]
    assert rep.stat().st_size > 0


def test_bad_lists_exit_2_naming_the_option_and_write_nothing(tmp_path):
    (tmp_path / "balls.yaml").write_text(BALLS)
    out = tmp_path / "cmp.json"
    for opt, value, named in (
        ("--n-balls", "1,3", "--n-balls 3"),
        ("--k", "2,x", "--k"),
        ("--criterion", "Q", "Q"),
    ):
        args = [*BASE, "--balls", str(tmp_path / "balls.yaml"), opt, value, "-o", str(out)]
        result = runner.invoke(app, args)
        assert result.exit_code == 2, result.output
        lines = result.output.strip().splitlines()
        assert len(lines) == 1 and named in lines[0]
        assert not out.exists()
