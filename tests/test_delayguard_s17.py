"""A loop cycling at twice the data's step is not an actuation delay (session 17, benchmarks/delayguard_s17.md).

ell5 case cold1: zone S's one box cycles every 30 min in 15-min data; a 1-step delay fitted the cycle's sampled
phase and passed the temperature-history test (ΔBIC 99.9 at the base structure), with no delay in the truth.
With the airflow low-passed by the centred [1, 2, 1]/4 filter in both equations it falls to −40; the battery's
true delays keep their evidence."""

from __future__ import annotations

import subprocess
import sys
import warnings

import numpy as np
import pytest

from hvacfmu.diagnosis import selection as S
from tests.test_delay_length_s15 import _scored


def test_lowpass_airflow_removes_a_two_step_cycle_without_shifting_slow_moves():
    from hvacfmu.models.causes.actuation_delay import lowpass_airflow

    k = np.arange(200, dtype=float)
    ramp = 0.5 + 0.01 * k
    out = lowpass_airflow(ramp + 0.2 * (-1.0) ** k)
    assert np.allclose(out[1:-1], ramp[1:-1])  # the cycle is gone, the ramp is not delayed
    u = np.r_[1.0, np.nan, 3.0, 4.0]
    assert np.all(np.isfinite(lowpass_airflow(u)[[0, 2, 3]]))  # a missing neighbour stands in with u(k)


def test_a_true_delay_keeps_its_evidence_with_the_airflow_low_passed():
    _, _, _, c = _scored([1, 2, 3, 4])
    assert c.term.delay == 3
    h = c.evidence["history_lowpass"]
    assert h["lowpass"] and h["delta_bic"] > S.DEFAULT_OPTIONS["bic_margin"]
    S._gate(c, S.DEFAULT_OPTIONS)
    assert c.status != "no evidence"


def test_the_gate_rejects_a_delay_that_only_the_two_step_cycle_supports():
    _, _, _, c = _scored([3])
    c.evidence["history_lowpass"] = {**c.evidence["history_lowpass"], "delta_bic": -40.0}
    S._gate(c, S.DEFAULT_OPTIONS)
    assert c.status == "no evidence" and "cycling at twice the data's step" in c.reason


@pytest.mark.slow
def test_ell5_cold1_meeting_room_cycle_is_not_a_delay(tmp_path):
    """The unseen-layout case itself (52 weeks, 15-min export): S passes the history test, not the low-pass one."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis.design import Within, make_signals
    from hvacfmu.fitting import fit
    from hvacfmu.models.causes.actuation_delay import ActuationDelay

    d = tmp_path / "cold1"
    cmd = [sys.executable, "-m", "hvacfmu", "-q", "generate", str(d), "--layout", "ell5", "--hvac", "reheat-dual"]
    cmd += ["--climate", "cold", "--units", "us", "--clock", "naive-local", "--fault", "outages"]
    cmd += ["--start", "2025-09-01", "--weeks", "52", "--export-step", "900", "--seed", "1"]
    subprocess.run(cmd, check=True, capture_output=True)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(d / "measurements.parquet", d / "building.toml")
        base = fit(ds, "zones", progress=False, use_solar=False, heat="airflow", open_loop=False)
    sig = make_signals(ds, base)
    W = Within(sig.group, sig.rows("train"))
    t = ActuationDelay(zone="S", delay=1)
    margin = S.DEFAULT_OPTIONS["bic_margin"]
    assert S.delay_given_history(sig, W, [], t)["delta_bic"] > margin  # the old gate let it through
    assert S.delay_given_history(sig, W, [], t, True)["delta_bic"] <= margin
