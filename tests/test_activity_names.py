"""Activity names of real event logs as formula atoms: readable, deterministic, unique, valid."""

from __future__ import annotations

import pytest

from tleaf_cli.atom_names import atom_problem
from tleaf_cli.data.activity_names import activity_atom, activity_atoms


@pytest.mark.parametrize(
    ("name", "atom"),
    [
        ("Assign seriousness", "assign_seriousness"),
        ("3", "a3"),
        ("W_Completeren aanvraag", "w_completeren_aanvraag"),
        ("Réunion (2nd)", "reunion_2nd"),
        ("  ER Triage  ", "er_triage"),
        ("Last step", "alast_step"),
        ("true", "atrue"),
        ("日本", "ri_ben"),
        ("検査", "jian_zha"),
        ("Straße", "strasse"),
        ("", "activity"),
    ],
)
def test_an_activity_reads_as_a_readable_atom(name: str, atom: str) -> None:
    assert activity_atom(name) == atom
    assert atom_problem(atom) is None


def test_names_that_meet_get_numbered_suffixes_and_atoms_keep_themselves() -> None:
    names = ["A b", "a b", "a_b", "a_b_2", "x"]
    atoms = activity_atoms(names)
    assert atoms["a_b"] == "a_b" and atoms["a_b_2"] == "a_b_2" and atoms["x"] == "x"
    assert sorted([atoms["A b"], atoms["a b"]]) == ["a_b_3", "a_b_4"]
    assert len(set(atoms.values())) == len(atoms) == len(names)
    assert all(atom_problem(a) is None for a in atoms.values())


def test_the_map_depends_on_the_set_of_names_not_their_order() -> None:
    names = ["Résumé", "resume", "RESUME", "3", "03", "Close"]
    assert activity_atoms(names) == activity_atoms(list(reversed(names)))
    assert activity_atoms(names + names) == activity_atoms(names)
