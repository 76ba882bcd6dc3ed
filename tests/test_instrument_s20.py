"""The neighbour-held instrument's first stages through the normal equations (session 20, issue 15).

:func:`coupling_instrument_beyond_neighbours` fitted each zone's first stages with two SVD least squares of the
stacked instruments (5-min ``core9``: 26k × 288); :func:`fitted_values` gives the same fitted values from one Gram
matrix, and falls back to numpy's ``lstsq`` where the columns are empty, collinear or badly conditioned
(``benchmarks/instrument_s20.md``).
"""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from hvacfmu.diagnosis.selection import fitted_values


def _lstsq_fitted(A, V):
    return A @ np.linalg.lstsq(A, V, rcond=None)[0]


def _matrices():
    rng = np.random.default_rng(20)
    n, m = 600, 24
    A = rng.standard_normal((n, m))
    yield "random", A
    # lagged differences of a slow signal: the instruments' kind of columns
    u = np.cumsum(rng.standard_normal(n + m))
    du = np.diff(u, prepend=u[0])
    yield "lags", np.column_stack([du[m - k : n + m - k] for k in range(m)])
    Z = A.copy()
    Z[:, 3] = 0.0  # a zone whose airflow never moves
    yield "zero column", Z
    D = A.copy()
    D[:, 5] = D[:, 1]  # two identical columns
    yield "duplicate column", D
    L = A.copy()
    L[:, 7] = A[:, :3] @ [1.0, -2.0, 0.5]  # exactly collinear
    yield "collinear", L
    N = A.copy()
    N[:, 9] = A[:, 2] + 1e-7 * rng.standard_normal(n)  # nearly collinear: condition number ~1e7
    yield "near collinear", N
    S = A * np.logspace(-3, 3, m)  # badly scaled but well conditioned once scaled
    yield "scaled", S
    yield "one column", A[:, :1]


@pytest.mark.parametrize("name,A", list(_matrices()), ids=[n for n, _ in _matrices()])
def test_fitted_values_match_lstsq(name, A):
    rng = np.random.default_rng(7)
    V = np.column_stack([A @ rng.standard_normal(A.shape[1]) + rng.standard_normal(A.shape[0]) for _ in range(3)])
    ref = _lstsq_fitted(A, V)
    got = fitted_values(A, V)
    assert_allclose(got, ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    # with the caller's Gram matrix, as the held instrument passes it (and its neighbours' block)
    assert_allclose(fitted_values(A, V, A.T @ A), ref, rtol=0, atol=1e-9 * np.abs(ref).max())
    B = A[:, A.shape[1] // 2 :]
    ref_b = _lstsq_fitted(B, V[:, :1])
    got_b = fitted_values(B, V[:, :1], (A.T @ A)[A.shape[1] // 2 :, A.shape[1] // 2 :])
    assert_allclose(got_b, ref_b, rtol=0, atol=1e-9 * np.abs(ref_b).max())


def test_fitted_values_without_columns():
    V = np.ones((5, 2))
    assert_allclose(fitted_values(np.empty((5, 0)), V), np.zeros((5, 2)), rtol=0, atol=0)


# ---------------------------------------------------------------------------------------------------------------
# the first-stage F floor of the neighbour-held instrument (coupling_instrument_min_F)


def _iv(t: float, coef: float, F: tuple, zones=("NW", "SE")) -> dict:
    return {
        "iv_coef": coef,
        "iv_t": t,
        **{f"iv_coef_{z}": coef for z in zones},
        **{f"iv_first_F_{z}": f for z, f in zip(zones, F)},
    }


def _candidate(held_F: tuple, plain_t: float = -0.1):
    """A coupling NW+SE scored zone by zone whose neighbour-held instrument passes its t (2.5) on a first stage of
    first-stage F ``held_F`` (the false NW+SE of default battery 2027 clean case 11 under ``"replace"`` had a weak
    held first stage in NW)."""
    from types import SimpleNamespace

    from hvacfmu.models.causes import ZoneCoupling

    return SimpleNamespace(
        cause="zone_coupling",
        test={"delta_bic": 249.0},
        evidence={
            "scored_alone": True,
            "symmetry_ratio": 1.0,
            "instrument": _iv(plain_t, 0.01 * plain_t, (8.6, 36.0)),
            "instrument_neighbours": _iv(2.5, 0.02, held_F),
        },
        term=ZoneCoupling(zone_a="NW", zone_b="SE", coef_ab=0.01, coef_ba=0.01),
        status="not tested",
        reason="",
    )


def _gate(c, **options):
    from hvacfmu.diagnosis import selection as S

    S._gate(c, {**S.DEFAULT_OPTIONS, **options})
    return c


def test_weak_held_first_stage_is_no_evidence():
    """Fails on main (no floor): a held instrument passing its t on a first stage of F 5.8 accepted the pair. Default
    2027 clean case 11 under ``"replace"``: the false NW+SE had held t 12.7 on NW's first-stage F 7.0."""
    c = _gate(_candidate((5.8, 43.0)), coupling_instrument_neighbours="replace", coupling_instrument_min_F=10.0)
    assert c.status == "no evidence"
    assert "weak first stage" in c.reason and "5.8" in c.reason
    # a strong first stage in both zones passes the same gate
    c = _gate(_candidate((12.0, 43.0)), coupling_instrument_neighbours="replace", coupling_instrument_min_F=10.0)
    assert c.status == "not tested"
    # the floor applies where the held instrument gates: in the default mode too, behind a passing plain instrument
    c = _gate(_candidate((5.8, 43.0), plain_t=3.0), coupling_instrument_min_F=10.0)
    assert c.status == "no evidence" and "weak first stage" in c.reason
    # the default floor is 10 (session 20): fails on main, where the pair passes
    c = _gate(_candidate((5.8, 43.0)), coupling_instrument_neighbours="replace")
    assert c.status == "no evidence" and "weak first stage" in c.reason and "< 10" in c.reason
    # and 0 is no floor
    c = _gate(_candidate((5.8, 43.0)), coupling_instrument_neighbours="replace", coupling_instrument_min_F=0.0)
    assert c.status == "not tested"
