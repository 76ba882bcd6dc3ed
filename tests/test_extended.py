"""ExtendedModel: terms, simulation, hidden states, persistence, evaluation."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from hvacfmu.errors import ModelError
from hvacfmu.models import load_model, model_from_dict
from hvacfmu.models.extended import (
    ActuationDelay,
    ExtendedModel,
    InternalGainSchedule,
    Reheat,
    SolarGain,
    SupplyAirBilinear,
    ThermalMass,
    UnusedInput,
    ZoneCoupling,
    dst_active,
    ema_series,
)
from hvacfmu.models.linear import LinearZoneModel

TZ = "America/Los_Angeles"


def _base(nv=3):
    dist = ("T_out", "T_supply", "I_S")[:nv]
    gains = {"fall": np.tile(np.linspace(0.0, 0.3, 672)[:, None], (1, 2))}
    return LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2", "V3"),
        input_map=np.array([[1.0, 1.0, 0.0], [0.0, 0.0, 1.0]]),
        disturbances=dist,
        A=np.array([[0.9, 0.02], [0.03, 0.88]]),
        B=np.diag([-0.2, -0.3]),
        C=np.array([[0.02, 0.03, 0.0005], [0.02, 0.03, 0.0]])[:, :nv],
        gains=gains,
    )


ALL_TERMS = (
    ThermalMass(zone="A", alpha=0.02, beta=0.05),
    ActuationDelay(zone="B", delay=2),
    SolarGain(zone="B", facade="W", coef=0.001),
    Reheat(zone="B", coef=0.05, u_min=0.05, T_threshold=12.0),
    ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.01, coef_ba=0.02),
    SupplyAirBilinear(zone="A", coef=0.05),
    InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(1.0, 0.5), dates=("2025-09-03",)),
)


def _frame(n=400, seed=0):
    rng = np.random.default_rng(seed)
    idx = pd.date_range("2025-09-01", periods=n, freq="15min", tz=TZ, name="time")
    return pd.DataFrame(
        {
            "T_A": 21 + rng.normal(0, 0.3, n),
            "T_B": 22 + rng.normal(0, 0.3, n),
            "m_V1": rng.uniform(0.05, 0.3, n),
            "m_V2": rng.uniform(0.05, 0.3, n),
            "m_V3": rng.uniform(0.04, 0.4, n),
            "T_out": 12 + rng.normal(0, 3, n),
            "T_supply": 14 + rng.normal(0, 0.2, n),
            "I_S": rng.uniform(0, 500, n),
            "I_W": rng.uniform(0, 400, n),
        },
        index=idx,
    )


def test_without_terms_equals_the_linear_model():
    base = _base()
    m = ExtendedModel(base=base)
    f = _frame()
    u, v = m.signals(f)
    q = m.gains_at(f.index, "fall")
    x0 = m.initial_state(f, 0)
    _, Y1 = m.simulate(x0, u, v, q)
    _, Y2 = base.simulate(base.initial_state(f, 0), *base.signals(f), base.gains_at(f.index, "fall"))
    assert_allclose(Y1, Y2, rtol=0, atol=1e-12)


def test_state_layout_and_disturbances():
    m = ExtendedModel(base=_base(), terms=ALL_TERMS)
    assert m.n_states == 2 + 1 + 2
    assert m.state_names == ("T_A", "T_B", "s_A", "u_B_lag2", "u_B_lag1")
    # I_W is added for the solar term; base columns keep their order
    assert m.disturbances == ("T_out", "T_supply", "I_S", "I_W")
    assert m.causes == tuple(t.cause for t in ALL_TERMS)


def test_each_term_adds_its_equation():
    base = _base()
    x = np.array([21.0, 23.0])
    u = np.array([0.3, 0.2])
    v = np.array([10.0, 14.0, 300.0, 200.0])
    q = np.array([0.1, 0.2])
    x_lin = base.step_state(x, u, v[:3], q)
    cases = [
        (SolarGain(zone="B", facade="W", coef=0.001), np.array([0.0, 0.001 * 200.0])),
        (SupplyAirBilinear(zone="A", coef=0.05), np.array([0.05 * 0.3 * (14.0 - 21.0), 0.0])),
        (ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.01, coef_ba=0.02), np.array([0.01 * 2.0, -0.02 * 2.0])),
        (Reheat(zone="B", coef=0.05, u_min=0.25, T_threshold=12.0), np.array([0.0, 0.05])),
        (Reheat(zone="B", coef=0.05, u_min=0.1, T_threshold=12.0), np.array([0.0, 0.0])),
    ]
    for term, extra in cases:
        m = ExtendedModel(base=base, terms=(term,))
        vv = v if "I_W" in m.disturbances else v[:3]
        assert_allclose(m.step_state(x, u, vv, q), x_lin + extra, rtol=0, atol=1e-12, err_msg=term.cause)


def test_thermal_mass_and_delay_dynamics():
    base = _base()
    m = ExtendedModel(base=base, terms=(ThermalMass(zone="A", alpha=0.1, beta=0.2), ActuationDelay(zone="B", delay=2)))
    x = np.array([21.0, 23.0, 19.0, 0.5, 0.4])  # T_A, T_B, s_A, u_B(k-2), u_B(k-1)
    u = np.array([0.3, 0.2])
    v = np.array([10.0, 14.0, 300.0])
    q = np.zeros(2)
    xn = m.step_state(x, u, v, q)
    expect_T = base.step_state(x[:2], np.array([0.3, 0.5]), v, q)  # B's airflow acts two steps late
    expect_T[0] += 0.2 * (19.0 - 21.0)
    assert_allclose(xn[:2], expect_T, rtol=0, atol=1e-12)
    assert_allclose(xn[2], 19.0 + 0.1 * (21.0 - 19.0), rtol=0, atol=1e-12)
    assert_allclose(xn[3:], [0.4, 0.2], rtol=0, atol=0)


def test_batched_simulation_matches_single():
    m = ExtendedModel(base=_base(), terms=ALL_TERMS)
    f = _frame()
    u, v = m.signals(f)
    q = m.gains_at(f.index, "fall")
    x0 = np.stack([m.initial_state(f, k) for k in (100, 200)])
    U = np.stack([u[100:196], u[200:296]])
    V = np.stack([v[100:196], v[200:296]])
    Q = np.stack([q[100:196], q[200:296]])
    _, Yb = m.simulate(x0, U, V, Q)
    for i in range(2):
        _, Y = m.simulate(x0[i], U[i], V[i], Q[i])
        assert_allclose(Yb[i], Y, rtol=0, atol=1e-12)


def test_initial_state_reads_history():
    m = ExtendedModel(
        base=_base(), terms=(ThermalMass(zone="A", alpha=0.05, beta=0.1), ActuationDelay(zone="B", delay=3))
    )
    f = _frame()
    x = m.initial_state(f, 150)
    assert_allclose(x[:2], f[["T_A", "T_B"]].iloc[150].to_numpy(), rtol=0, atol=0)
    # the filter over the history equals the teacher-forced state at that row
    X = m.teacher_forced_states(f)
    assert_allclose(x[2], X[150, 2], rtol=0, atol=0.02)  # [K] truncated history (5/alpha steps)
    assert_allclose(x[3:], f["m_V3"].iloc[147:150].to_numpy(), rtol=0, atol=0)
    # at the first row: no history
    x0 = m.initial_state(f, 0)
    assert_allclose(x0[2], f["T_A"].iloc[0], rtol=0, atol=0)
    assert_allclose(x0[3:], f["m_V3"].iloc[0], rtol=0, atol=0)


def test_ema_series_holds_gaps():
    y = np.array([1.0, np.nan, 3.0, 3.0])
    s = ema_series(y, 0.5)
    assert_allclose(s, [1.0, 1.0, 1.0, 2.0], rtol=0, atol=1e-12)


def test_holiday_and_dst_gain_adjustments():
    base = _base()
    prof = np.asarray(base.gains["fall"])
    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(1.0, 0.5), dates=("2025-09-03",))
    m = ExtendedModel(base=base, terms=(hol,))
    idx = pd.date_range("2025-09-02", periods=3 * 96, freq="15min", tz=TZ)
    q = m.gains_at(idx, "fall")
    q0 = base.gains_at(idx, "fall")
    wed = idx.date == pd.Timestamp("2025-09-03").date()
    assert_allclose(q[~wed], q0[~wed], rtol=0, atol=0)
    sunday = prof[6 * 96 : 7 * 96]
    assert_allclose(q[wed, 0], sunday[:, 0], rtol=0, atol=1e-12)
    assert_allclose(q[wed, 1], q0[wed, 1] + 0.5 * (sunday[:, 1] - q0[wed, 1]), rtol=0, atol=1e-12)
    dst = InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(1.0, 1.0), shift=-4)
    md = ExtendedModel(base=base, terms=(dst,))
    idx2 = pd.DatetimeIndex([pd.Timestamp("2025-10-01 10:00", tz=TZ), pd.Timestamp("2025-12-01 10:00", tz=TZ)])
    assert list(dst_active(idx2)) == [True, False]
    qd = md.gains_at(idx2, "fall")
    tow = (2 * 96 + 40, 0 * 96 + 40)  # Wednesday / Monday 10:00
    assert_allclose(qd[0], prof[tow[0] - 4], rtol=0, atol=1e-12)
    assert_allclose(qd[1], prof[tow[1]], rtol=0, atol=1e-12)


def test_calendar_holiday_is_not_moved_twice_by_the_gain_schedule_terms():
    # the base model's calendar already reads Sunday's profile on 2025-10-01 (a Wednesday, daylight saving on):
    # a holiday term listing the day must not add Sunday-minus-Wednesday again, and a dst_shift term must shift
    # Sunday's profile there, not Wednesday's
    import dataclasses

    base = dataclasses.replace(_base(), holidays=("2025-10-01",))
    prof = np.asarray(base.gains["fall"])
    idx = pd.date_range("2025-10-01", periods=96, freq="15min", tz=TZ)
    sunday = prof[6 * 96 : 7 * 96]
    assert_allclose(base.gains_at(idx, "fall"), sunday, rtol=0, atol=0)
    hol = InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(1.0, 0.5), dates=("2025-10-01",))
    assert_allclose(ExtendedModel(base=base, terms=(hol,)).gains_at(idx, "fall"), sunday, rtol=0, atol=1e-12)
    dst = InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(1.0, 1.0), shift=-4)
    q = ExtendedModel(base=base, terms=(dst,)).gains_at(idx, "fall")
    assert_allclose(q[4:], sunday[:-4], rtol=0, atol=1e-12)  # Sunday read an hour earlier
    assert_allclose(q[:4], prof[6 * 96 - 4 : 6 * 96], rtol=0, atol=1e-12)  # before 01:00: Saturday's last hour


def test_json_roundtrip_and_load_model(tmp_path):
    m = ExtendedModel(base=_base(), terms=ALL_TERMS, meta={"name": "x"})
    path = m.save(tmp_path / "ext.json")
    m2 = load_model(path)
    assert isinstance(m2, ExtendedModel)
    assert m2.to_dict() == json.loads(path.read_text())
    f = _frame()
    u, v = m.signals(f)
    q = m.gains_at(f.index, "fall")
    _, Y1 = m.simulate(m.initial_state(f, 10), u[10:60], v[10:60], q[10:60])
    _, Y2 = m2.simulate(m2.initial_state(f, 10), u[10:60], v[10:60], q[10:60])
    assert_allclose(Y1, Y2, rtol=0, atol=0)


BAD_TERMS = [
    ({"cause": "teleport"}, "cause"),
    ({"cause": "solar_gain", "zone": "A", "facade": "X", "coef": 0.1}, "facade"),
    ({"cause": "solar_gain", "zone": "Q", "facade": "S", "coef": 0.1}, "not a zone"),
    ({"cause": "thermal_mass", "zone": "A", "alpha": 1.5, "beta": 0.1}, "alpha"),
    ({"cause": "actuation_delay", "zone": "A", "delay": 0}, "delay"),
    ({"cause": "zone_coupling", "zones": ["A", "A"], "coef_ab": 0.1, "coef_ba": 0.1}, "two different zones"),
    ({"cause": "reheat", "zone": "A", "coef": "x", "u_min": 0.1, "T_threshold": 10}, "number"),
    ({"cause": "internal_gain_schedule", "variant": "holiday", "coef": {"A": 1.0}, "dates": ["2025-13-01"]}, "ISO"),
]


@pytest.mark.parametrize("term, message", BAD_TERMS)
def test_bad_terms_are_rejected(term, message):
    d = ExtendedModel(base=_base()).to_dict()
    d["terms"] = [term]
    with pytest.raises(ModelError, match=message):
        model_from_dict(d)


def test_bad_file_structure():
    d = ExtendedModel(base=_base()).to_dict()
    with pytest.raises(ModelError, match="base"):
        model_from_dict({**d, "base": {"kind": "physics"}})
    with pytest.raises(ModelError, match="format_version"):
        model_from_dict({**d, "format_version": 99})
    with pytest.raises(ModelError, match="two actuation_delay"):
        ExtendedModel(base=_base(), terms=(ActuationDelay(zone="A", delay=1), ActuationDelay(zone="A", delay=2)))


def test_evaluate_accepts_extended_model():
    """The evaluation protocol scores an ExtendedModel like any ZoneModel."""
    from hvacfmu.building import building_from_dict
    from hvacfmu.data.dataset import Dataset
    from hvacfmu.evaluation import evaluate

    b = building_from_dict(
        {
            "name": "two",
            "latitude": 37.9,
            "longitude": -122.3,
            "timezone": TZ,
            "zones": [
                {
                    "name": "A",
                    "area": 100.0,
                    "volume": 300.0,
                    "adjacent": ["B"],
                    "facades": [{"orientation": "S", "window_area": 10.0}],
                },
                {
                    "name": "B",
                    "area": 80.0,
                    "volume": 240.0,
                    "adjacent": ["A"],
                    "facades": [{"orientation": "W", "window_area": 10.0}],
                },
            ],
            "vavs": [{"name": "V1", "zone": "A"}, {"name": "V2", "zone": "A"}, {"name": "V3", "zone": "B"}],
        }
    )
    n = 3 * 672
    f = _frame(n)
    f = f.drop(columns=["I_S", "I_W"]).assign(ghi=np.clip(np.sin(np.arange(n) / 96 * 2 * np.pi) * 600, 0, None))
    ds = Dataset.from_frame(f, b, step=900.0, seed=0)
    m = ExtendedModel(base=_base(), terms=ALL_TERMS)
    res = evaluate([m.base, m], ds)
    sc = res.scores[1]
    assert sc.kind == "extended"
    assert len(sc.starts) > 0 and np.all(np.isfinite(sc.rms))


# ----------------------------------------------------------------------------- equations (matrix form)
EQ_TERMS = [
    ThermalMass(zone="A", alpha=0.02, beta=0.05),
    ActuationDelay(zone="B", delay=2),
    ActuationDelay(zone="A", delay=1),
    SolarGain(zone="B", facade="W", coef=0.001),
    Reheat(zone="B", coef=0.05, u_min=0.4, T_threshold=15.0),
    Reheat(zone="A", coef=0.03, variant="discharge"),
    ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.01, coef_ba=0.02),
    SupplyAirBilinear(zone="A", coef=0.05),
    UnusedInput(zone="B", column="rh_V3", coef=0.2),
]


@pytest.mark.parametrize("term", EQ_TERMS, ids=lambda t: f"{t.cause}-{getattr(t, 'zone', '')}")
def test_equations_of_each_term_match_step_state(term):
    from hvacfmu.models.equations import check_equations

    m = ExtendedModel(base=_base(), terms=(term,))
    eq = m.equations()
    assert eq.n_states == m.n_states
    assert check_equations(m, eq, n=50, atol=1e-10) <= 1e-10


def test_equations_of_all_terms_together():
    from hvacfmu.models.equations import check_equations

    terms = (
        ThermalMass(zone="A", alpha=0.02, beta=0.05),
        ActuationDelay(zone="B", delay=3),
        SolarGain(zone="B", facade="W", coef=0.001),
        ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.01, coef_ba=0.02),
        SupplyAirBilinear(zone="A", coef=0.05),
        Reheat(zone="A", coef=0.05, u_min=0.4, T_threshold=15.0),
    )
    m = ExtendedModel(base=_base(), terms=terms)
    eq = m.equations()
    assert eq.bilinear and len(eq.switches) == 1
    check_equations(m, eq, n=80, atol=1e-10)


@pytest.mark.parametrize(
    "terms, message",
    [
        (
            (InternalGainSchedule(variant="holiday", zone_names=("A", "B"), coef=(1.0, 0.5), dates=("2025-09-03",)),),
            "calendar",
        ),
        ((InternalGainSchedule(variant="dst_shift", zone_names=("A", "B"), coef=(1.0, 1.0), shift=-4),), "calendar"),
        ((ActuationDelay(zone="A", delay=2), SupplyAirBilinear(zone="A", coef=0.05)), "quadratic in the state"),
        ((ActuationDelay(zone="B", delay=1), Reheat(zone="B", coef=0.05, u_min=0.4, T_threshold=15.0)), "delayed"),
    ],
)
def test_terms_without_time_invariant_equations_say_so(terms, message):
    m = ExtendedModel(base=_base(), terms=terms)
    with pytest.raises(ModelError, match=message):
        m.equations()


def test_discharge_reheat_reads_td_columns():
    """``Qrh_<zone>`` = Σ m cp (Td − T_supply)⁺ [kW] is derived from the frame's Td_ columns."""
    f = _frame()
    f["Td_V1"], f["Td_V2"] = 30.0, 14.0
    m = ExtendedModel(base=_base(), terms=(Reheat(zone="A", coef=0.03, variant="discharge"),))
    u, v = m.signals(f)
    q = v[:, m.disturbances.index("Qrh_A")]
    ts = f["T_supply"].to_numpy()
    expect = (
        f["m_V1"].to_numpy() * 1005.0 * (30.0 - ts) + f["m_V2"].to_numpy() * 1005.0 * np.maximum(14.0 - ts, 0.0)
    ) / 1000.0
    assert_allclose(q, expect, rtol=1e-12, atol=0)
    with pytest.raises(ModelError, match="Td_"):
        m.signals(_frame())


def test_discharge_reheat_reads_each_box_against_its_own_unit(tmp_path):
    """Two units: a box whose discharge air is its own unit's supply (a packaged unit, no coil) has no
    reheat, however warm that unit runs against the mean ``T_supply``; the mapping survives the file."""
    f = _frame()
    f["T_supply_U1"], f["T_supply_U2"], f["T_supply"] = 18.0, 13.0, 13.0  # U1 warmer than the (flow-weighted) mean
    f["Td_V1"], f["Td_V2"] = 18.0, 25.0  # V1: U1's air, untouched; V2 (on U2): heated by 12 K
    term = Reheat(zone="A", coef=0.03, variant="discharge", supply=(("V1", "T_supply_U1"), ("V2", "T_supply_U2")))
    m = ExtendedModel(base=_base(), terms=(term,))
    q = m.signals(f)[1][:, m.disturbances.index("Qrh_A")]
    assert_allclose(q, f["m_V2"].to_numpy() * 1005.0 * 12.0 / 1000.0, rtol=1e-12, atol=0)
    # against the mean supply temperature V1 would "reheat" by 5 K in every row
    q_mean = ExtendedModel(base=_base(), terms=(Reheat(zone="A", coef=0.03, variant="discharge"),)).signals(f)[1]
    assert_allclose(q_mean[:, m.disturbances.index("Qrh_A")] - q, f["m_V1"].to_numpy() * 1005.0 * 5.0 / 1000.0)
    path = tmp_path / "x.json"
    m.save(path)
    back = load_model(path)
    assert back.terms[0].supply == term.supply
    assert_allclose(back.signals(f)[1], m.signals(f)[1])
    bad = json.loads(path.read_text())
    bad["terms"][0]["supply"] = ["T_supply_U1"]
    with pytest.raises(ModelError, match="supply must map box names"):
        model_from_dict(bad)


def test_delivered_heat_base_keeps_its_form_in_the_extended_model():
    """A base in the delivered-heat form (Td inlets): the extended model steps it through the base's
    own equations, and its matrix form carries the base's bilinear terms."""
    from hvacfmu.models.equations import check_equations

    base = LinearZoneModel(
        kind="zones",
        step=900.0,
        outputs=("A", "B"),
        measured_zones=("A", "B"),
        output_weights=np.eye(2),
        vavs=("V1", "V2"),
        input_map=np.eye(2),
        disturbances=("T_out", "T_supply", "Td_V1"),
        A=np.array([[0.9, 0.02], [0.03, 0.88]]),
        B=np.zeros((2, 2)),
        C=np.array([[0.02, 0.0, 0.0], [0.02, 0.0, 0.0]]),
        gains={"fall": np.zeros((672, 2))},
        beta=np.array([0.05, 0.04]),
        inlets=("Td_V1", "T_supply"),
        heat_map=np.eye(2),
    )
    x, u, v, q = np.array([21.0, 22.0]), np.array([0.3, 0.2]), np.array([5.0, 14.0, 30.0]), np.zeros(2)
    assert_allclose(ExtendedModel(base=base).step_state(x, u, v, q), base.step_state(x, u, v, q), rtol=0, atol=1e-12)
    m = ExtendedModel(
        base=base,
        terms=(
            ThermalMass(zone="A", alpha=0.02, beta=0.05),
            ZoneCoupling(zone_a="A", zone_b="B", coef_ab=0.01, coef_ba=0.01),
        ),
    )
    check_equations(m, m.equations(), n=40, atol=1e-10)
    with pytest.raises(ModelError, match="quadratic"):
        ExtendedModel(base=base, terms=(ActuationDelay(zone="A", delay=1),)).equations()
