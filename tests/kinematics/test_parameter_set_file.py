"""Parameter-set file handling: the exact document written, every refusal of
:meth:`ParameterSet.from_document` with the key it names, covariance checks and
reordering, and the machine/model match."""

import json

import numpy as np
import pytest
import yaml

from mtmetrology.errors import InputError
from mtmetrology.io.files import InputFileError
from mtmetrology.kinematics import Machine
from mtmetrology.kinematics.parameter_set import MAX_MAGNITUDE, ParameterSet

NAME = "five-axis-wcbxfzyst"
HEADER = {"kind": "parameter-set", "version": 1, "machine": NAME}
X0C = {"name": "E_X0C", "value": 1, "unit": "µm"}
X0S = {"name": "E_X0S", "value": 2, "unit": "µm"}


@pytest.fixture(scope="module")
def machine():
    return Machine.load(NAME)


def _refusal(doc, machine) -> str:
    with pytest.raises(InputFileError) as err:
        ParameterSet.from_document(doc, machine, "p.json")
    return str(err.value)


def _two(machine, **kwargs) -> ParameterSet:
    # E_X0C = -104.59 µm, E_A0B = -8.73 µrad (Alami Mchichi (2018), Table 5.2 magnitudes)
    return ParameterSet(
        ("E_X0C", "E_A0B"),
        np.array([-104.59e-3, -8.73e-6]),
        ("µm", "µrad"),
        machine=NAME,
        **kwargs,
    )


def test_the_document_written(machine):
    cov = np.array([[0.48e-3**2, 1e-10], [1e-10, 0.86e-6**2]])
    pset = _two(machine, covariance=cov, provenance={"source": "test"}, model="13")
    doc = pset.to_document()
    assert list(doc) == [
        "kind",
        "version",
        "machine",
        "model",
        "parameters",
        "covariance",
        "provenance",
    ]
    assert (doc["kind"], doc["version"], doc["machine"], doc["model"]) == (
        "parameter-set",
        1,
        NAME,
        "13",
    )
    x0c, a0b = doc["parameters"]
    assert (x0c["name"], x0c["unit"], a0b["name"], a0b["unit"]) == (
        "E_X0C",
        "µm",
        "E_A0B",
        "µrad",
    )
    assert x0c["value"] == pytest.approx(-104.59, rel=1e-14)
    assert a0b["value"] == pytest.approx(-8.73, rel=1e-14)
    assert x0c["u"] == pytest.approx(0.48, rel=1e-14)
    assert a0b["u"] == pytest.approx(0.86, rel=1e-14)
    assert doc["covariance"]["names"] == ["E_X0C", "E_A0B"]
    # off-diagonal 1e-10 mm·rad = 1e-10 · 1e3 µm · 1e6 µrad = 1e-1 µm·µrad
    np.testing.assert_allclose(
        doc["covariance"]["matrix"], [[0.48**2, 0.1], [0.1, 0.86**2]], rtol=1e-12
    )
    assert doc["provenance"] == {"source": "test"}


def test_a_bare_set_writes_no_optional_keys(machine):
    bare = ParameterSet(("E_X0C",), np.array([1e-3]), ("µm",))
    assert bare.to_document() == {
        "kind": "parameter-set",
        "version": 1,
        "parameters": [{"name": "E_X0C", "value": 1.0, "unit": "µm"}],
    }
    assert bare.standard_uncertainty is None
    np.testing.assert_array_equal(bare.scales(), [1e-3])


@pytest.mark.parametrize("suffix", [".json", ".yaml", ".yml", ".txt"])
def test_save_writes_the_document_in_the_format_of_the_suffix(tmp_path, machine, suffix):
    pset = _two(machine, covariance=np.diag([1e-6, 1e-12]), model="13")
    path = tmp_path / f"p{suffix}"
    pset.save(path)
    text = path.read_text(encoding="utf-8")
    if suffix in (".yaml", ".yml"):
        assert yaml.safe_load(text) == pset.to_document()
        assert "µm" in text  # allow_unicode: the unit is written as it is read
    else:
        assert json.loads(text) == pset.to_document()
        assert text.endswith("}\n") and '\n  "version": 1,' in text and "µrad" in text
    back = ParameterSet.load(path, machine)
    assert (back.names, back.units, back.machine, back.model) == (
        pset.names,
        pset.units,
        NAME,
        "13",
    )
    np.testing.assert_allclose(back.values, pset.values, rtol=1e-14)
    np.testing.assert_allclose(back.covariance, pset.covariance, rtol=1e-14)


@pytest.mark.parametrize("suffix", [".json", ".yaml"])
def test_a_non_finite_value_is_not_written(tmp_path, machine, suffix):
    """Refused naming the parameter, in JSON and in YAML (which would write ``.nan``)."""
    values = np.array([1e-3, np.nan])
    pset = ParameterSet(("E_X0C", "E_Y0C"), values, ("µm", "µm"), machine=NAME)
    target = tmp_path / f"p{suffix}"
    with pytest.raises(InputError, match=r"p\.\w+: E_Y0C is not finite; nothing written$"):
        pset.save(target)
    covariance = np.diag([1e-6, np.inf])
    pset = ParameterSet(("E_X0C", "E_Y0C"), values[:1].repeat(2), ("µm", "µm"),
                        covariance=covariance, machine=NAME)  # fmt: skip
    with pytest.raises(InputError, match="covariance row E_Y0C is not finite"):
        pset.save(target)
    assert not target.exists()


def test_zeros_and_vector_for(machine):
    z = ParameterSet.zeros(machine)
    assert z.names == machine.parameter_names and z.units == machine.parameter_units
    assert (z.machine, z.model) == (NAME, "13")
    np.testing.assert_array_equal(z.values, np.zeros(13))
    pset = _two(machine)
    v = pset.vector_for(machine)
    expected = np.zeros(13)
    expected[machine.parameter_names.index("E_X0C")] = -104.59e-3
    expected[machine.parameter_names.index("E_A0B")] = -8.73e-6
    np.testing.assert_array_equal(v, expected)
    with pytest.raises(ValueError) as err:
        ParameterSet(("E_XX9", "E_X0C", "E_XX8"), np.zeros(3), ("µm",) * 3).vector_for(machine)
    assert str(err.value) == "machine model lacks E_XX8, E_XX9"


def test_machine_for(machine):
    same = ParameterSet.zeros(machine)
    assert same.machine_for(machine) is machine
    sub = _two(machine).machine_for(machine)
    assert sub.parameter_names == ("E_X0C", "E_A0B")
    with pytest.raises(InputFileError) as err:
        ParameterSet(("E_X0C",), np.zeros(1), ("µm",), machine="other").machine_for(machine)
    assert str(err.value) == f"parameter set: made for machine 'other', not '{NAME}'"


def test_check_machine_names_the_models(machine):
    pset = ParameterSet(("E_X0C",), np.zeros(1), ("µm",), machine=NAME, model="9")
    with pytest.raises(InputFileError) as err:
        pset.check_machine(machine, "p.json")
    assert str(err.value) == f"p.json: error model '9' is not a model of {NAME} (models: 13, 84)"
    # no machine and no model recorded: nothing to refuse
    ParameterSet(("E_X0C",), np.zeros(1), ("µm",)).check_machine(machine)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ([X0C], "p.json: a parameter set must be a mapping"),
        (
            {**HEADER, "kind": "x", "parameters": [X0C]},
            "p.json: kind: 'x' is not a parameter set (expected 'parameter-set' or a "
            "calibration result: samba-calibration, ballplate-calibration, tracker-calibration, "
            "iso230-2-positioning, iso230-4-calibration, r-test)",
        ),
        (
            {**HEADER, "version": 2, "parameters": [X0C]},
            "p.json: version: 2 is not supported (1 is)",
        ),
        (
            {**HEADER, "model": 13, "parameters": [X0C]},
            "p.json: model: must be a string, got 13",
        ),
        (
            {"kind": "parameter-set", "version": 1, "parameters": [X0C]},
            f"p.json: machine: missing; name the machine the set belongs to (here '{NAME}')",
        ),
        ({**HEADER, "parameters": []}, "p.json: parameters: must be a non-empty list"),
        ({**HEADER, "parameters": X0C}, "p.json: parameters: must be a non-empty list"),
        (HEADER, "p.json: parameters: must be a non-empty list"),
        (
            {**HEADER, "parameters": [X0C, {"name": "E_X0S", "value": 1}]},
            "p.json: parameters[1]: needs 'name', 'value' and 'unit'",
        ),
        (
            {**HEADER, "parameters": [["E_X0C", 1, "µm"]]},
            "p.json: parameters[0]: needs 'name', 'value' and 'unit'",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "b": 1, "a": 2}]},
            "p.json: parameters[0]: a: unknown key",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "name": 7}]},
            "p.json: parameters[0]: name must be a string, got 7",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "unit": 1}]},
            "p.json: parameters[0] (E_X0C): unit must be a string",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "value": 1e6 + 1}]},
            "p.json: parameters[0] (E_X0C): value 1e+06 µm is beyond 1e+06 µm; "
            "no machine has such an error",
        ),
        (
            {**HEADER, "parameters": [X0C, X0S, X0C]},
            "p.json: parameter(s) listed twice: E_X0C",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "u": 1}, X0S]},
            "p.json: E_X0S: u missing while others have one",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "u": -1}]},
            "p.json: parameters[0] (E_X0C): u must be >= 0 (a standard uncertainty), got -1",
        ),
        (
            {
                **HEADER,
                "parameters": [{**X0C, "u": -1}],
                "covariance": {"names": ["E_X0C"], "matrix": [[1e-6]]},
            },
            "p.json: parameters[0] (E_X0C): u must be >= 0 (a standard uncertainty), got -1",
        ),
        (
            {**HEADER, "parameters": [{**X0C, "u": "1"}]},
            "p.json: E_X0C: u: '1' is not a number",
        ),
        (
            {**HEADER, "parameters": [X0C], "provenance": [1]},
            "p.json: provenance: must be a mapping",
        ),
    ],
)
def test_refusals_name_the_key(machine, doc, message):
    assert _refusal(doc, machine) == message


def test_the_largest_magnitude_is_accepted_in_any_unit(machine):
    doc = {**HEADER, "parameters": [{**X0C, "value": -MAX_MAGNITUDE}]}
    assert ParameterSet.from_document(doc, machine).values[0] == -1e3  # 1e6 µm = 1 m
    doc = {**HEADER, "parameters": [{**X0C, "value": 1001.0, "unit": "mm"}]}
    assert _refusal(doc, machine) == (
        "p.json: parameters[0] (E_X0C): value 1001 mm is beyond 1e+06 µm; "
        "no machine has such an error"
    )


def test_zero_uncertainties_and_provenance_are_kept(machine):
    doc = {
        **HEADER,
        "model": "13",
        "parameters": [{**X0C, "u": 0}, {**X0S, "u": 0.5}],
        "provenance": {"by": "me"},
    }
    pset = ParameterSet.from_document(doc, machine)
    np.testing.assert_allclose(pset.covariance, np.diag([0.0, 0.5e-3**2]), rtol=1e-15)
    assert pset.provenance == {"by": "me"} and pset.model == "13"
    doc["provenance"] = None
    assert ParameterSet.from_document(doc, machine).provenance == {}


def test_a_calibration_result_is_read_as_its_parameter_set(machine):
    doc = {**HEADER, "kind": "samba-calibration", "parameters": [X0C], "residuals": [1, 2]}
    pset = ParameterSet.from_document(doc, machine)
    assert pset.names == ("E_X0C",) and pset.values[0] == 1e-3
    assert pset.covariance is None and pset.standard_uncertainty is None
    doc["kind"] = "ballplate-calibration"
    assert ParameterSet.from_document(doc, machine).names == ("E_X0C",)


def _with_covariance(block):
    return {
        **HEADER,
        "parameters": [X0C, {"name": "E_A(0Z)B", "value": 3, "unit": "µrad"}],
        "covariance": block,
    }


def test_the_covariance_is_reordered_and_converted(machine):
    # listed in the other order, and with the parameter's long name: E_A(0Z)B is E_A0B
    block = {"names": ["E_A0B", "E_X0C"], "matrix": [[4.0, 0.5], [0.5, 9.0]]}
    pset = ParameterSet.from_document(_with_covariance(block), machine)
    # µm² -> mm², µm·µrad -> mm·rad, µrad² -> rad²
    np.testing.assert_allclose(pset.covariance, [[9.0e-6, 0.5e-9], [0.5e-9, 4.0e-12]], rtol=1e-15)
    np.testing.assert_allclose(pset.standard_uncertainty, [3e-3, 2e-6], rtol=1e-15)
    # a singular (rank-one) but positive semi-definite matrix is accepted
    block = {"names": ["E_X0C", "E_A0B"], "matrix": [[1.0, 1.0], [1.0, 1.0]]}
    assert ParameterSet.from_document(_with_covariance(block), machine).covariance.shape == (2, 2)


@pytest.mark.parametrize(
    ("block", "message"),
    [
        ([[1, 0], [0, 1]], "covariance needs exactly 'names' and 'matrix'"),
        ({"names": ["E_X0C", "E_A0B"]}, "covariance needs exactly 'names' and 'matrix'"),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0], [0, 1]], "units": []},
            "covariance needs exactly 'names' and 'matrix'",
        ),
        (
            {"names": "E_X0C", "matrix": [[1, 0], [0, 1]]},
            "covariance.names must be a list of names",
        ),
        (
            {"names": ["E_X0C", 5], "matrix": [[1, 0], [0, 1]]},
            "covariance.names must be a list of names",
        ),
        (
            {"names": ["E_X0C", "E_X0S"], "matrix": [[1, 0], [0, 1]]},
            "covariance names differ from the parameter names",
        ),
        ({"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0]]}, "covariance.matrix must be 2x2"),
        ({"names": ["E_X0C", "E_A0B"], "matrix": "I"}, "covariance.matrix must be 2x2"),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0], [0]]},
            "covariance.matrix row 1 must have 2 entries",
        ),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0], 7]},
            "covariance.matrix row 1 must have 2 entries",
        ),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0], [True, 1]]},
            "covariance.matrix[1][0]: True is not a number",
        ),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 1e-3], [1.001e-3, 1]]},
            "covariance.matrix: covariance matrix is not symmetric (max |C − Cᵀ| = 1e-06, "
            "above 1e-09 × max |C| = 1e-09)",
        ),
        (
            {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0], [0, -1e-6]]},
            "covariance matrix is not positive semi-definite",
        ),
    ],
)
def test_covariance_refusals(machine, block, message):
    assert _refusal(_with_covariance(block), machine) == "p.json: " + message


def test_a_covariance_symmetric_to_rounding_is_accepted(machine):
    block = {"names": ["E_X0C", "E_A0B"], "matrix": [[1, 0.5], [0.5 * (1 + 1e-12), 1]]}
    pset = ParameterSet.from_document(_with_covariance(block), machine)
    assert pset.covariance[0, 0] == pytest.approx(1e-6, rel=1e-15)


def test_a_covariance_asymmetric_by_rounding_of_small_entries_reads_back_symmetric(
    machine, tmp_path
):
    """Issue 30: entries near 1e-7 whose mirrors differ by 3e-16 (elementwise 3e-9
    relative, refused by the old rtol=1e-9 rule) are read, exactly symmetric; the file
    written again is exactly symmetric."""
    block = {
        "names": ["E_X0C", "E_A0B"],
        "matrix": [[0.25, 1.234e-7], [1.234e-7 + 3e-16, 0.04]],
    }
    pset = ParameterSet.from_document(_with_covariance(block), machine, "t.json")
    np.testing.assert_array_equal(pset.covariance, pset.covariance.T)
    assert pset.covariance[0, 1] == pytest.approx((1.234e-7 + 1.5e-16) * 1e-9, rel=1e-12)
    pset.save(tmp_path / "again.json")
    matrix = np.array(json.loads((tmp_path / "again.json").read_text())["covariance"]["matrix"])
    np.testing.assert_array_equal(matrix, matrix.T)
    # a relative asymmetry of 1e-6 of the largest entry is refused, naming file and field
    block["matrix"][1][0] = 1.234e-7 + 1e-6 * 0.25
    message = _refusal(_with_covariance(block), machine)
    assert message.startswith("p.json: covariance.matrix: covariance matrix is not symmetric")


def test_the_writer_writes_an_exactly_symmetric_matrix(machine):
    cov = np.array([[0.48e-3**2, 1e-10], [1e-10 * (1 + 1e-13), 0.86e-6**2]])
    matrix = np.array(_two(machine, covariance=cov).to_document()["covariance"]["matrix"])
    np.testing.assert_array_equal(matrix, matrix.T)


def test_a_calibrated_tool_round_trips_and_is_put_on_the_machine(machine, tmp_path):
    """tool_mm is written, read back exactly, and replaces the machine's nominal tool."""
    tool = np.array([0.0123, -0.0045, machine.tool[2] - 0.0321])
    pset = _two(machine, tool=tool)
    pset.save(tmp_path / "p.json")
    assert json.loads((tmp_path / "p.json").read_text(encoding="utf-8"))["tool_mm"] == list(tool)
    back = ParameterSet.load(tmp_path / "p.json", machine)
    np.testing.assert_array_equal(back.tool, tool)
    np.testing.assert_array_equal(back.machine_for(machine).tool, tool)
    assert ParameterSet.load(tmp_path / "p.json", machine).machine_for(machine) is not machine
    assert _two(machine).machine_for(machine).tool is machine.tool  # none: the nominal


@pytest.mark.parametrize("bad", [[1, 2], [1, "2", 3], "0,0,1"])
def test_a_malformed_tool_is_refused_naming_the_key(machine, bad):
    assert "tool_mm" in _refusal({**HEADER, "parameters": [X0C], "tool_mm": bad}, machine)
