"""The term budget of ``diagnose`` (``max_terms``): when it stops the selection, the report names what it left.

Data: the three rooms of ``test_diagnosis`` with two simulated effects (solar gain in A, a 30-min delay in C), as in
``test_two_synthetic_effects_are_both_found``: both are significant and cross-validated in the first round.
"""

from __future__ import annotations

import json

import pytest
from test_diagnosis import two_effects_case, two_effects_report

from hvacfmu.diagnosis import diagnose
from hvacfmu.diagnosis.selection import BUDGET_STATUS, term_budget

EFFECTS = {"solar_gain": {"zone": "A", "facade": "S"}, "actuation_delay": {"zone": "C", "delay": 2}}


@pytest.fixture(scope="module")
def two_effects():
    ds, base = two_effects_case()  # the data of test_two_synthetic_effects_are_both_found, simulated once per worker
    return ds, base


def test_a_budget_that_binds_names_the_significant_candidates_it_left(two_effects, tmp_path):
    ds, base = two_effects
    rep = diagnose(ds, model=base, progress=False, max_terms=1)
    # the budget is a maximum: one term, although the round had two zone-disjoint candidates to accept
    assert len(rep.findings) == 1, rep.summary()
    (kept,) = rep.causes
    (other,) = set(EFFECTS) - {kept}
    assert rep.budget["reached"] and rep.budget["max_terms"] == 1 and rep.budget["n_terms"] == 1
    left = [c for c in rep.budget["left"] if c["cause"] == other]
    assert left and left[0]["location"] == {**left[0]["location"], **EFFECTS[other]}, rep.budget
    assert left[0]["delta_bic"] > rep.options["bic_margin"]
    # the same candidate, with its status and why, among the report's candidates
    (cand,) = [c for c in rep.candidates if c["cause"] == other and c["location"] == left[0]["location"]]
    assert cand["status"] == BUDGET_STATUS and "max_terms = 1" in cand["reason"]
    assert rep.rounds[-1]["stopped"] == "max_terms" and rep.rounds[-1]["accepted"] == []
    # said in the text, the one-line summary and the JSON
    text = rep.format()
    assert "Term budget reached: the selection stopped at max_terms = 1 terms" in text
    assert f"  - {other} at " in text.split("Term budget reached")[1].split("\n\n")[0]
    assert "stopped at the term budget (max_terms 1)" in rep.summary()
    d = json.loads(rep.save_json(tmp_path / "r.json").read_text())
    assert d["budget"]["reached"] is True and [c["cause"] for c in d["budget"]["left"]][:1] == [other]


def test_a_budget_that_does_not_bind_says_so(two_effects):
    ds, base = two_effects
    rep = diagnose(ds, model=base, progress=False, max_terms=2)
    assert sorted(rep.causes) == sorted(EFFECTS), rep.summary()
    assert rep.budget["reached"] is True and rep.budget["left"] == []  # spent, nothing significant left
    rep3 = two_effects_report()  # diagnose(ds, model=base): the default budget, 20 at 3 zones (shared, once per worker)
    assert rep3.causes == rep.causes
    assert rep3.budget == {"max_terms": 20, "rule": "max(20, 4 × 3 zones)", "n_terms": 2, "reached": False, "left": []}
    assert rep3.options["max_terms"] == 20 and rep.budget["rule"] == "given"
    assert "Term budget" not in rep3.format() and "term budget" not in rep3.summary()
    assert all(c["status"] != BUDGET_STATUS for c in rep3.candidates)


@pytest.mark.parametrize(
    "given, nz, budget", [(None, 3, 20), (None, 5, 20), (None, 6, 24), (None, 8, 32), (None, 9, 36), (7, 8, 7)]
)
def test_default_term_budget_scales_with_the_zones(given, nz, budget):
    """A fixed 20 was 7 terms per zone at 3 zones and 2.5 at 8 (the EnergyPlus apartments stopped on it)."""
    assert term_budget(given, nz) == budget


def test_cli_max_terms_and_what_the_budget_left_in_text_and_json(two_effects, tmp_path, cli):
    # in-process (the ``cli`` fixture): the real ``python -m hvacfmu.cli diagnose`` subprocess is
    # test_diagnosis.py::test_cli_diagnose_then_evaluate
    ds, base = two_effects
    frame = ds.frame.drop(columns=[c for c in ds.frame.columns if c.startswith("I_") or c == "excitation"])
    frame.reset_index().to_csv(tmp_path / "data.csv", index=False)
    ds.building.save(tmp_path / "building.toml")
    base.save(tmp_path / "base.json")
    args = ["-q", "diagnose", tmp_path / "data.csv", "-b", tmp_path / "building.toml", "-m", tmp_path / "base.json"]
    r = cli(*args, "--max-terms", "1", "--json", tmp_path / "r.json")
    assert r.returncode == 0, r.stderr[-3000:]
    d = json.loads((tmp_path / "r.json").read_text())
    assert len(d["findings"]) == 1 and d["budget"]["reached"] and d["budget"]["max_terms"] == 1
    (other,) = set(EFFECTS) - {d["findings"][0]["cause"]}
    block = r.stdout.split("Term budget reached")[1].split("\n\n")[0]
    assert f"  - {other} at " in block, r.stdout
