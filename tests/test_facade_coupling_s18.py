"""Couplings of zones sharing a facade: the instrument with weather controls (session 18, issue 15).

Option ``coupling_shared_weather`` (with ``coupling_alone_shared``): a pair sharing a facade orientation, scored
zone by zone, must also pass the instrument check with the weather controls of :func:`weather_controls` (the
shared facades' irradiance and its low-pass at 3, 12, 48 h, the outdoor temperature low-passed at the same time
constants) in both zones' equations, and each zone's own instrumented coefficient must then be positive.
``benchmarks/facade_coupling_s18.md``.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_diagnosis import ExtendedModel, ZoneCoupling, row_model, simulate_dataset

from hvacfmu.data.dataset import Dataset


def _weather_driven(model, weeks=12, seed=0, follow=6.0, size=0.02):
    """``model``'s data with an unmodelled weather load in A and C (``size`` K/step per K of the outdoor
    temperature low-passed at 12 h, against its mean) that both boxes follow: each box's airflow rises by
    ``follow`` kg/s per K/step of the load (cooling scheduled on the weather), on top of random airflow moves."""
    from hvacfmu.models.causes.signals import ema_series

    rng = np.random.default_rng(seed + 7)
    ds0 = simulate_dataset(row_model(), weeks=weeks, seed=seed)
    frame = ds0.frame.copy()
    n = len(frame)
    tout = frame["T_out"].to_numpy()
    load = size * (ema_series(tout, 900.0 / (12 * 3600.0)) - tout.mean())
    u, v = model.signals(frame)
    q = np.zeros((n, 3))
    for s in np.unique(ds0.season_of_row):
        m = ds0.season_of_row == s
        q[m] = model.gains_at(frame.index[m], s)
    q[:, [0, 2]] += load[:, None]
    base_u = rng.uniform(0.1, 0.5, (n // 4 + 1, 3)).repeat(4, axis=0)[:n]
    x = np.full(3, 21.0)
    Y, M = np.empty((n, 3)), np.empty((n, 3))
    for k in range(n):
        Y[k] = x
        uk = np.clip(base_u[k] + follow * load[k] * np.array([1.0, 0.0, 1.0]), 0.05, 0.6)
        M[k] = uk
        x = model.step_state(x, uk, v[k], q[k]) + rng.normal(0, 0.02, 3)
    for j, z in enumerate("ABC"):
        frame[f"T_{z}"] = Y[:, j]
        frame[f"m_V{j + 1}"] = M[:, j]
    return Dataset.from_frame(frame, ds0.building, step=900.0, seed=seed)


def _instrument(ds, with_controls):
    from hvacfmu.diagnosis import selection as S
    from hvacfmu.diagnosis.design import Within, make_signals

    sig = make_signals(ds, row_model())
    W = Within(sig.group, sig.rows("train"))
    ctl = S.weather_controls(sig, [])[1] if with_controls else None
    return S.coupling_instrument(sig, W, [], ZoneCoupling(zone_a="A", zone_b="C"), 24, controls=ctl)


def test_weather_controls_remove_a_weather_load_the_boxes_follow():
    """A weather load shared by A and C that both boxes follow passes the plain instrument (the partner's airflow
    moves carry the weather's past); with the outdoor temperature's low-passed anomaly in both equations it
    does not. A real exchange passes with the same controls."""
    from hvacfmu.diagnosis.design import make_signals
    from hvacfmu.diagnosis.selection import WEATHER_CONTROL_TAUS_H, weather_controls

    ds = _weather_driven(row_model())
    names, cols = weather_controls(make_signals(ds, row_model()), [])
    assert names == [f"T_out low-passed {tau:g} h" for tau in WEATHER_CONTROL_TAUS_H] and cols.shape[1] == 3
    plain, ctl = _instrument(ds, False), _instrument(ds, True)
    # measured: plain 0.032 per step, t 2.8; with the controls −0.003, t −1.1
    assert plain["iv_coef"] > 0 and plain["iv_t"] >= 2.0
    assert ctl["iv_t"] < 1.0
    real = ExtendedModel(base=row_model(), terms=(ZoneCoupling(zone_a="A", zone_b="C", coef_ab=0.04, coef_ba=0.04),))
    iv = _instrument(_weather_driven(real, follow=0.0, size=0.0), True)
    # measured: 0.039, t 19.8
    assert abs(iv["iv_coef"] - 0.04) < 0.006 and iv["iv_t"] > 5.0


def _couplings(d, found=True):
    return [c for c in d["findings" if found else "candidates"] if c["cause"] == "zone_coupling"]


@pytest.mark.slow
def test_weather_controls_reject_row4_clean_case_0_end_zones():
    """README battery 2026 clean case 0 (``row4``, seed 42): ``coupling_alone_shared`` alone reports a false R1+R4
    coupling (``benchmarks/coupling_row4_s17.md``: +3.5 %, instrument t 2.8); with ``coupling_shared_weather`` the
    instrument with the weather of R1's and R4's facades in both equations falls below t 2 and nothing is found."""
    from hvacfmu.data import prepare
    from hvacfmu.diagnosis import diagnose
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=16, seed=42, effects=[], layout="row4")
    ds = prepare(paths.measurements, paths.building, step=900.0)
    d = diagnose(ds, progress=False, coupling_alone_shared=True, coupling_shared_weather=True).to_dict()
    assert _couplings(d) == []
    (c,) = [c for c in _couplings(d, found=False) if sorted(c["location"]["zones"]) == ["R1", "R4"]]
    iv, ivw = c["evidence"]["instrument"], c["evidence"]["instrument_weather"]
    # measured: plain 0.053 per step, t 2.6; with the controls 0.026, t 1.7
    assert iv["iv_t"] >= 2.0 and ivw["iv_t"] < 2.0
    assert "I_W low-passed 12 h" in ivw["controls"] and "I_E" in ivw["controls"]
    assert c["status"] == "no evidence" and "beyond the weather of their facades" in c["reason"]
