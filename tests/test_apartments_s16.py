"""A cycling unit holds its setpoint whatever share of the step it runs (session 16, EnergyPlus mid-rise apartments).

A split unit or furnace with a cycling fan has no minimum airflow: its step-averaged airflow is its duty cycle times
its full flow. ``held_setpoint`` read such a unit as running only above 5 % of its 99th-percentile airflow, so the
steps in which the thermostat ran it briefly (the apartments: 7 % of the cooling steps, 97-100 % of them ending at
24.0 °C) let the model's open-loop prediction run free. A unit without a minimum airflow now runs whenever it moves
air; a box with a minimum airflow keeps the old rule (``benchmarks/apartments_s16.md``).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_diagnosis import row_model

from hvacfmu.models.causes import HeldSetpoint
from hvacfmu.models.extended import ExtendedModel

FULL = 0.2  # the unit's full airflow [kg/s]


def _cycling_unit(n=4000, seed=3):
    """A zone a cycling cooling unit holds at 24.0 °C: half of its running steps are short runs (1-4 % duty)."""
    rng = np.random.default_rng(seed)
    T = rng.uniform(22.0, 27.0, n)
    run = rng.random(n) < 0.6
    duty = np.where(rng.random(n) < 0.5, rng.uniform(0.01, 0.04, n), rng.uniform(0.2, 1.0, n))
    u = np.where(run, FULL * duty, 0.0)
    T[1:][run[:-1]] = 24.0  # after any step in which the unit ran, the zone is at its cooling setpoint
    return T, u, np.full(n, 12.5)


def test_a_cycling_unit_runs_whenever_it_moves_air():
    T, u, Ts = _cycling_unit()
    term, _ = HeldSetpoint.learn("A", T, u, Ts, np.arange(len(T)), u_min=0.0)
    assert term.cooling_floor == pytest.approx(24.0)
    short = u[(u > 0) & (u < 0.05 * FULL)]
    assert len(short) > 500
    assert term.u_on < short.min()  # a short run is a run (main: 5 % of q99, above every short run)
    # the held model holds the setpoint in a step of 1 % duty, as the data do
    held = ExtendedModel(
        base=row_model(), terms=(HeldSetpoint(zone="A", cooling_floor=24.0, u_on=term.u_on, hold=True),)
    )
    x, v, q = np.array([24.6, 24.0, 24.0]), np.array([10.0, 12.5]), np.zeros(3)
    assert held.step_state(x, np.array([0.01 * FULL, 0.0, 0.0]), v, q)[0] == 24.0
    free = ExtendedModel(base=row_model()).step_state(x, np.zeros(3), v, q)[0]
    assert held.step_state(x, np.zeros(3), v, q)[0] == free  # no airflow at all: the unit is off, the zone free


def test_a_box_with_a_minimum_airflow_keeps_its_threshold():
    T, u, Ts = _cycling_unit()
    u_min = 0.02
    u = np.where(u > 0, np.maximum(u, u_min), u_min)  # a VAV box never goes below its minimum
    term, _ = HeldSetpoint.learn("A", T, u, Ts, np.arange(len(T)), u_min=u_min)
    q = float(np.quantile(u, 0.99))
    assert term.u_on == pytest.approx(max(1.05 * u_min, 0.05 * q) + 1e-6)  # unchanged since session 14


def test_a_units_mode_is_read_from_its_own_supply_air():
    """Split units: one flat heats while the others cool, and the airflow-weighted ``T_supply`` of every unit is
    cold. The zone's own unit's supply air says it heats, so the held model holds its heating setpoint."""
    base = row_model()
    t = HeldSetpoint(zone="A", heating_ceiling=21.1, u_on=0.001, hold=True, supply="T_supply_own")
    m = ExtendedModel(base=base, terms=(t,))
    assert m.disturbances[-1] == "T_supply_own"
    x, q = np.array([20.5, 24.0, 24.0]), np.zeros(3)
    u = np.array([0.01, 0.2, 0.2])
    v = np.array([0.0, 13.0, 34.0])  # T_out, weighted T_supply (the cooling units dominate), the zone's own unit
    assert m.step_state(x, u, v, q)[0] == 21.1
    again = ExtendedModel.from_dict(m.to_dict())
    assert again.terms == (t,) and again.to_dict()["terms"][0]["supply"] == "T_supply_own"


def test_the_held_stage_reads_the_zones_own_unit():
    from types import SimpleNamespace

    from hvacfmu.diagnosis.held import own_supply

    base = SimpleNamespace(outputs=("A", "B"), vavs=("a", "b"), input_map=np.eye(2))
    sig = SimpleNamespace(
        zones=("A", "B"),
        base=base,
        supply_of={"a": "T_supply_U1", "b": "T_supply"},
        extra={"T_supply_U1": np.zeros(3)},
    )
    assert own_supply(sig, 0) == "T_supply_U1"
    assert own_supply(sig, 1) == "T_supply"  # no unit column of its own: the weighted supply, as before


def test_a_unit_at_full_airflow_stops_at_its_setpoint_but_does_not_hold_it():
    """``hold`` stands for a thermostat with spare capacity: at full airflow the apartments' units end the step at
    24.0 °C in 16-27 % of the steps only, so there the zone may stay above the setpoint (only the floor applies)."""
    T, u, Ts = _cycling_unit()
    u[::50] = np.where(u[::50] > 0, FULL, 0.0)  # some running steps flat out
    term, _ = HeldSetpoint.learn("A", T, u, Ts, np.arange(len(T)), u_min=0.0)
    assert term.u_full == pytest.approx(0.99 * np.quantile(u, 0.99))
    t = HeldSetpoint(zone="A", cooling_floor=24.0, u_on=term.u_on, hold=True, u_full=term.u_full)
    m = ExtendedModel(base=row_model(), terms=(t,))
    x, v, q = np.array([25.0, 24.0, 24.0]), np.array([30.0, 12.5]), np.zeros(3)
    full = m.step_state(x, np.array([FULL, 0.0, 0.0]), v, q)[0]
    assert full > 24.0  # flat out and still above its setpoint: not held
    assert full == ExtendedModel(base=row_model()).step_state(x, np.array([FULL, 0.0, 0.0]), v, q)[0]
    assert m.step_state(x, np.array([0.5 * FULL, 0.0, 0.0]), v, q)[0] == 24.0  # spare capacity: held
    again = ExtendedModel.from_dict(m.to_dict())
    assert again.terms == (t,) and again.to_dict()["terms"][0]["u_full"] == pytest.approx(term.u_full)
