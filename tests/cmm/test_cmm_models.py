"""Tests for mtmetrology.cmm.models (bridge-CMM error models and their datum by rank)."""

import pytest

from mtmetrology.cmm.models import (
    SQUARENESS,
    choose_datum,
    machine_for_model,
    parse_model,
)
from mtmetrology.errors import InputError


def test_parse_model_names_and_degrees():
    seed = parse_model(" seed ")
    assert seed.is_seed and seed.name == "seed" and seed.degrees is None
    full = parse_model("full-2", "E_YX=0, E_AZ=3")
    assert full.name == "full-2[E_YX=0,E_AZ=3]" and not full.is_seed
    assert full.degrees["E_YX"] == 0 and full.degrees["E_AZ"] == 3
    assert full.degrees["E_XX"] == 2 and len(full.degrees) == 18


@pytest.mark.parametrize(
    ("text", "overrides", "message"),
    [
        ("full-6", None, "--model 'full-6': use seed, auto or full-<d> with d in 1..5"),
        ("bogus", None, "--model 'bogus': use seed, auto or full-<d> with d in 1..5"),
        ("seed", "E_YX=1", "--degrees applies to a full-<d> model, not to the seed model"),
    ],
)
def test_parse_model_refusals(text, overrides, message):
    with pytest.raises(InputError) as info:
        parse_model(text, overrides)
    assert str(info.value) == message


@pytest.mark.parametrize("item", ["E_QQ=1", "E_YX=9", "E_YX"])
def test_a_bad_degree_override_names_the_item(item):
    with pytest.raises(InputError) as info:
        parse_model("full-2", item)
    assert str(info.value).startswith(f"--degrees {item!r}: expected FUNCTION=DEGREE with ")


@pytest.mark.parametrize(
    ("text", "overrides"), [("full-1", None), ("full-2", "E_YX=0,E_AZ=3"), ("full-3", None)]
)
def test_full_models_have_every_degree_0_to_d_and_the_squareness_errors(base, text, overrides):
    choice = parse_model(text, overrides)
    machine = machine_for_model(base, choice)
    expected = sum(d + 1 for d in choice.degrees.values() if d > 0) + len(SQUARENESS)
    assert machine.n_params == expected
    assert machine.model_name == choice.name
    assert set(SQUARENESS) <= set(machine.parameter_names)
    if overrides:
        assert not any(n.startswith("E_YX") for n in machine.parameter_names)
        assert "E_AZ3" in machine.parameter_names


def test_seed_model_is_the_definitions_21_chebyshev(base):
    machine = machine_for_model(base, parse_model("seed"))
    assert machine.model_name == "21-chebyshev"
    assert machine.parameter_names == base.parameter_names


def test_datum_drops_constants_and_straightness_slopes(base):
    """Constant terms are plate shifts/rotations; three slopes are squareness (§2.6)."""
    d = choose_datum(machine_for_model(base, parse_model("full-1")))
    dropped = {n for n, _ in d.dropped}
    assert {f"E_{c}{a}0" for a in "XYZ" for c in "XYZABC"} <= dropped
    assert {"E_XY1", "E_ZX1", "E_ZY1"} <= dropped
    assert set(SQUARENESS) <= set(d.kept)
    assert dict(d.dropped)["E_XY1"] == ("E_C0X",)


def test_an_equivalent_datum_keeps_as_many_terms(base):
    """Preferring the straightness slopes drops the squareness errors instead: the rank
    (number of kept terms) does not depend on the choice, and each squareness error is the
    slope it replaces."""
    machine = machine_for_model(base, parse_model("full-1"))
    default = choose_datum(machine)
    slopes = ("E_XY1", "E_ZX1", "E_ZY1")
    alt = choose_datum(machine, prefer=slopes)
    assert len(alt.kept) == len(default.kept)
    assert set(slopes) <= set(alt.kept)
    partners = dict(alt.dropped)
    assert (partners["E_C0X"], partners["E_B0Z"], partners["E_A0Z"]) == (
        ("E_XY1",),
        ("E_ZX1",),
        ("E_ZY1",),
    )
    doc = alt.to_dict()
    assert doc["kept"] == list(alt.kept)
    assert {"name": "E_C0X", "combination_of": ["E_XY1"]} in doc["dropped"]
