"""diagnose, fitting its own base, says that its extended model is not compared with `fit`'s models (session 21).

On the EnergyPlus secondary school the extended model predicted worse than `hvacfmu fit --model zones` (0.766 K
against 0.636 K, ``benchmarks/unseen_s21.md``) and nothing in the report said so.
"""

from types import SimpleNamespace

import hvacfmu.fitting
from hvacfmu.diagnosis import pipeline


def test_own_base_fit_notes_that_fit_models_may_predict_better(monkeypatch):
    base = SimpleNamespace(heat="airflow")
    monkeypatch.setattr(hvacfmu.fitting, "fit", lambda dataset, kind, **kw: base)
    dataset = SimpleNamespace(building=SimpleNamespace(zone_names=("a", "b")))
    notes: list = []
    model, given = pipeline._base_model(dataset, None, lambda *a: None, notes)
    assert model is base and not given
    (note,) = [n for n in notes if "not compared with the models `hvacfmu fit` gives" in n]
    assert "-m extended.json -m zones.json" in note


def test_a_given_base_gets_no_such_note(monkeypatch):
    base = SimpleNamespace(heat="airflow")
    import hvacfmu.models.base as mb
    import hvacfmu.models.loadcheck as lc

    monkeypatch.setattr(mb, "building_mismatch", lambda *a: ((), ()))
    monkeypatch.setattr(lc, "require_box_drive", lambda *a: None)
    notes: list = []
    model, given = pipeline._base_model(SimpleNamespace(building=None), base, lambda *a: None, notes)
    assert given and model is base and notes == []
