"""Two causes reading one measured column compete for one gain (issue 15, point 2).

The EnergyPlus bed named the Core's discharge heat ``unused_input Td_VAV_Core_mid`` on one selection
path and discharge ``reheat`` on another (``benchmarks/diagnosis_energyplus_s12.md``): both read the
box's ``Td``. A column brought into a zone's equation by one cause is not named again by another
(``Term.sources``), and of the two the one the evidence favours is the finding, the other its rival.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest
from test_diagnosis import ROW, row_model, simulate_dataset

from hvacfmu.building import building_from_dict
from hvacfmu.data.dataset import Dataset
from hvacfmu.diagnosis import selection
from hvacfmu.diagnosis.candidates import generate, shared_sources
from hvacfmu.diagnosis.report import _finding_lines
from hvacfmu.models.causes import Candidate
from hvacfmu.models.causes.signals import Within, make_signals
from hvacfmu.models.causes.unused_input import UnusedInput
from hvacfmu.models.extended import Reheat, SupplyAirBilinear


def _signals_with_discharge_air():
    """The three rooms with every box's discharge air measured (its coil heats it 0–8 K above the supply)."""
    ds = simulate_dataset(row_model(), weeks=2, seed=3, ghi=False)
    frame = ds.frame.copy()
    rng = np.random.default_rng(5)
    for v in ("V1", "V2", "V3"):
        frame[f"Td_{v}"] = frame["T_supply"] + np.clip(rng.normal(2.0, 3.0, len(frame)), 0.0, 8.0)
    ds2 = Dataset.from_frame(frame, building_from_dict(ROW), step=900.0, seed=3)
    return make_signals(ds2, row_model())


def test_sources_name_the_measured_columns_a_term_brings_in():
    sig = _signals_with_discharge_air()
    rh = Reheat(zone="B", variant="discharge", supply=(("V2", "T_supply"),))
    assert rh.sources(sig) == {"Td_V2"}  # its regressor Qrh_B is built from V2's discharge air (no rh_ measured)
    assert Reheat(zone="B", u_min=0.05, T_threshold=12.0).sources(sig) == frozenset()  # airflow and T_out only
    assert UnusedInput(zone="B", column="rh_V2").sources(sig) == {"Td_V2", "rh_V2"}  # one coil's heat
    assert UnusedInput(zone="B", column="Td_V2").sources(sig) == {"Td_V2"}
    assert SupplyAirBilinear(zone="B").sources(sig) == {"T_supply"}
    assert shared_sources(sig, rh, UnusedInput(zone="B", column="Td_V2")) == ["Td_V2"]
    assert shared_sources(sig, rh, UnusedInput(zone="A", column="Td_V2")) == []  # another zone's equation


def test_a_column_an_accepted_term_reads_is_not_named_again_by_another_cause():
    """With discharge reheat in B accepted, ``unused_input Td_V2`` in B is not tested (before: screened and
    scored again, the same heat under a second cause name); A's own Td_V1 still is."""
    sig = _signals_with_discharge_air()
    W = Within(sig.group, sig.rows("train"))
    resid = np.random.default_rng(0).normal(0.0, 0.02, (len(W.rows), sig.nz))
    resid_all = np.full((len(sig.Y), sig.nz), np.nan)
    resid_all[W.rows] = resid
    terms = [Reheat(zone="B", variant="discharge", supply=(("V2", "T_supply"),))]
    cands = generate(sig, terms, W, resid, {**selection.DEFAULT_OPTIONS, "_resid_all": resid_all})
    by = {c.key: c for c in cands}
    taken = by["unused_input(column=Td_V2,zone=B)"]
    assert taken.status == "no evidence", taken.status
    assert "Td_V2" in taken.reason and "reheat" in taken.reason
    assert taken.evidence["column_taken_by"]["cause"] == "reheat"
    assert by["unused_input(column=Td_V1,zone=A)"].status == "not tested"


def _duel(monkeypatch, o_offset: float):
    """``unused_input Td_V2`` (cross-validated t 2.9) against discharge ``reheat`` in B (t 2.4) through
    :func:`selection._confirm_round`, the cross-validation replaced by fixed fold scores: 12 weeks, the
    reheat's windows ``o_offset`` [K] worse than the unused input's, plus noise."""
    sig = SimpleNamespace(zones=("A", "B", "C"))
    plan = SimpleNamespace(week_of_start=[np.arange(12)], folds=[0])
    rng = np.random.default_rng(1)
    base = 1.0 + 0.05 * rng.normal(size=(12, 1))
    with_c = base - 0.03 + 0.01 * rng.normal(size=(12, 1))
    with_o = with_c + o_offset + 0.01 * rng.normal(size=(12, 1))
    ui = UnusedInput(zone="B", column="Td_V2")
    rh = Reheat(zone="B", variant="discharge", supply=(("V2", "T_supply"),))
    c = Candidate("unused_input", {"zone": "B", "column": "Td_V2"}, [ui], 0)
    o = Candidate("reheat", {"zone": "B", "variant": "discharge"}, [rh], 0)
    c.term, o.term = ui, rh
    c.test, o.test = {"delta_bic": 40.0}, {"delta_bic": 30.0}
    cv = {
        id(c): ({"n_weeks": 12, "gain_abs": 0.03, "gain_percent": 3.1, "se_percent": 1.1, "t": 2.9}, [with_c]),
        id(o): ({"n_weeks": 12, "gain_abs": 0.05, "gain_percent": 5.2, "se_percent": 2.2, "t": 2.4}, [with_o]),
    }

    def fake_cv(sig_, plan_, terms_, cand, base_scores):
        cand.cv, base_scores[("with", id(cand))] = cv[id(cand)]

    monkeypatch.setattr(selection, "cross_validate", fake_cv)
    accepted = selection._confirm_round(sig, plan, [], [c, o], dict(selection.DEFAULT_OPTIONS), None, None)
    return accepted, c, o


def test_one_column_under_two_causes_names_the_specific_cause_when_the_folds_cannot_tell(monkeypatch):
    """Before: the higher t named ``unused_input`` (2.9 over 2.4), a coin flip on the EnergyPlus bed."""
    accepted, c, o = _duel(monkeypatch, 0.0)
    assert accepted == [o] and o.status == "found" and c.status == "no evidence"
    rv = o.evidence["rival"]
    assert rv["cause"] == "unused_input" and rv["shared_columns"] == ["Td_V2"]
    assert abs(rv["head_to_head_t"]) < 2.0 and "cannot tell them apart" in rv["why"]
    assert "Td_V2" in c.reason and "reheat" in c.reason
    f = {"cause": o.cause, "location": o.location, "test": {"lr": 50, "lr_adjusted": 45, "dof": 1, "delta_bic": 30}}
    f["evidence"] = o.evidence
    line = next(x for x in _finding_lines(1, f) if "competing cause" in x)
    assert "unused_input" in line and "both read Td_V2: one gain; reheat is named" in line


@pytest.mark.parametrize("offset, named", [(0.03, "unused_input"), (-0.03, "reheat")])
def test_one_column_under_two_causes_goes_to_the_better_one_when_the_folds_decide(monkeypatch, offset, named):
    accepted, c, o = _duel(monkeypatch, offset)
    (f,) = accepted
    assert f.cause == named and f.evidence["rival"]["shared_columns"] == ["Td_V2"]
    loser = c if f is o else o
    assert loser.status == "no evidence" and "better on the same folds" in loser.reason


def test_a_copy_of_a_column_the_model_reads_is_not_an_unused_input():
    """One air handler: its ``T_supply_U1`` is the frame's ``T_supply`` (EnergyPlus: ``T_supply_PACU_VAV_mid``).
    Before, ``unused_input T_supply_U1`` was screened and scored in every zone: a second, unbounded
    coefficient on the supply temperature the model reads (4 false findings on the EnergyPlus bed)."""
    import json

    ds = simulate_dataset(row_model(), weeks=2, seed=3, ghi=False)
    d = json.loads(json.dumps(ROW))
    d["ahus"] = [{"name": "U1"}]
    for v in d["vavs"]:
        v["ahu"] = "U1"
    frame = ds.frame.copy()
    frame["T_supply_U1"] = frame["T_supply"]
    sig = make_signals(Dataset.from_frame(frame, building_from_dict(d), step=900.0, seed=3), row_model())
    W = Within(sig.group, sig.rows("train"))
    resid = np.random.default_rng(0).normal(0.0, 0.02, (len(W.rows), sig.nz))
    cands = [c for c in UnusedInput.screen(sig, [], W, resid, {}) if c.location["column"] == "T_supply_U1"]
    assert len(cands) == 3
    assert all(c.status == "no evidence" and not c.variants for c in cands), [c.status for c in cands]
    assert "same values as T_supply" in cands[0].reason
