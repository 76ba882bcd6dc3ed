"""A delay's runners-up are lengths of a delay its one-step pick established: the cross-validation judges them
without the one-step ΔBIC, except a variant whose delayed airflow does not act (session 16,
benchmarks/diagnosis_holiday_s16.md: quad4 case 14, 30 min true, ΔBIC −357 at 30 min, cross-validated +25.7 %
against +7.8 % at the one-step pick's 15 min)."""

from __future__ import annotations

import pytest

from hvacfmu.diagnosis import selection as S
from tests.test_delay_length_s15 import _scored


@pytest.mark.slow
def test_a_runner_up_below_the_one_step_gate_is_cross_validated_unless_its_airflow_does_not_act(monkeypatch):
    sig, W, plan, c = _scored([1])
    _, _, _, c3 = _scored([3])
    low = {**c3.test, "delta_bic": -100.0}  # the one-step fit rejects the true length (as on quad4 case 14)
    alt = {"term": c3.term, "test": low, "W": W, "opts": S.DEFAULT_OPTIONS}
    c.alternatives = [alt]
    S.cross_validate(sig, plan, [], c, {})
    ev = c.evidence["delay_length_cv"]
    assert ev["one_step_pick"] == 1 and ev["picked"] == 3 and set(ev["gain_percent_by_delay"]) == {"1", "3"}
    assert c.term.delay == 3 and c.test["delta_bic"] == -100.0
    reason = S._found_reason(c, S.DEFAULT_OPTIONS)
    assert reason.startswith(f"ΔBIC {ev['one_step_pick_delta_bic']:.1f} > 10 at 1 step(s) (one-step pick), length 3")

    # the same runner-up when its delayed airflow's coefficient sits at the bound 0 given the zone's history
    sig, W, plan, c = _scored([1])
    c.alternatives = [{**alt, "W": W}]
    real = S.delay_given_history
    monkeypatch.setattr(S, "delay_given_history", lambda *a: {**real(*a), "b": 0.0} if a[3].delay == 3 else real(*a))
    S.cross_validate(sig, plan, [], c, {})
    assert set(c.evidence["delay_length_cv"]["gain_percent_by_delay"]) == {"1"} and c.term.delay == 1
