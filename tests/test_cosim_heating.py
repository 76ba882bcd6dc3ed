"""Heating through the plant's discharge air commands (issue 13 p.3): plant inputs, harness, rule sequence.

The plant FMU takes optional ``Td_<vav>`` [°C] inputs; unset (or at the supply air) a box discharges at its
supply temperature, exactly as before. The rule controller heats like a single-maximum VAV reheat
sequence: minimum airflow, then the discharge air from the supply temperature up to the heating limit.
"""

from __future__ import annotations

import dataclasses
import json
import warnings

import numpy as np
import pandas as pd
import pytest
from numpy.testing import assert_allclose

from harness.controllers import DEFAULT_T_DISCHARGE_MAX, RuleController
from harness.cosim import CP_AIR, run_cosim
from hvacfmu.emulator import Plant
from hvacfmu.emulator.effects import EmulatorError
from hvacfmu.errors import HvacfmuWarning

BAND = (22.5, 24.5)  # [°C] warm enough that an October day needs heat in every zone


@pytest.fixture(scope="module")
def short_data(short_paths):
    from hvacfmu.data import prepare

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        return prepare(short_paths.measurements, short_paths.building)


@pytest.fixture(scope="module")
def plant_fmu(tmp_path_factory, short_paths):
    from hvacfmu.fmu import export_plant_fmu

    return export_plant_fmu(short_paths.truth, tmp_path_factory.mktemp("plant") / "Plant.fmu")


def day_span(data):
    week = data.weeks[-1]
    return dict(start=week.start, stop=week.start + pd.Timedelta(days=1), warmup=86400.0)


class Fixed:
    """Boxes at fixed airflows; discharge air ``T_supply + rise`` for every box (``rise=None``: no command)."""

    name = "fixed"

    def __init__(self, rise=None):
        self.rise = rise

    def reset(self, context):
        self.m = context.box_limits()[0] * 1.2
        self.n_td = len(context.discharge)

    def __call__(self, k, t, y, v):
        if self.rise is None:
            return self.m
        return np.concatenate([self.m, np.full(self.n_td, float(v["T_supply"]) + self.rise)])


class AirflowOnlyRule(RuleController):
    """The rule controller as it was before discharge commands (the plant's Td inputs hidden from it)."""

    def reset(self, context):
        super().reset(dataclasses.replace(context, discharge=()))


def test_plant_discharge_reheat(short_paths):
    plant = Plant.from_truth(json.loads(short_paths.truth.read_text()))
    n = len(plant.vavs)
    m = np.linspace(0.1, 0.5, n)
    assert_allclose(plant.discharge_reheat(m, 14.0, np.full(n, 0.0)), 0.0, rtol=0, atol=0)  # unset: no reheat
    Td = np.full(n, 30.0)
    Td[0] = 10.0  # below the supply air: a box cannot cool, no reheat
    p = plant.discharge_reheat(m, 14.0, Td)
    assert p[0] == 0.0
    assert_allclose(p[1:], m[1:] * CP_AIR * 16.0, rtol=1e-12, atol=0)  # [W]
    with pytest.raises(EmulatorError, match="T_discharge must have"):
        plant.discharge_reheat(m, 14.0, np.full(n - 1, 30.0))
    with pytest.raises(EmulatorError, match="T_supply must be one value"):
        plant.discharge_reheat(m, [14.0, 15.0, 16.0], Td)


def test_plant_fmu_discharge_inputs(plant_fmu, short_data):
    """Td at the supply air is bit-identical to no command; Td above it heats, and the summary's heating
    energy is Σ m c_p (Td - T_supply) · step."""
    span = day_span(short_data)
    runs = {rise: run_cosim(plant_fmu, short_data, Fixed(rise), **span) for rise in (None, 0.0, 10.0)}
    zones = [f"T_{z}" for z in short_data.building.zone_names]
    base = runs[None].table[zones].to_numpy()
    assert_allclose(runs[0.0].table[zones].to_numpy(), base, rtol=0, atol=0)
    assert runs[None].summary["heating_kWh"] == 0.0 == runs[0.0].summary["heating_kWh"]
    hot = runs[10.0]
    assert np.all(hot.table[zones].to_numpy()[4:] > base[4:] + 0.05)  # every zone warmer after an hour
    vavs = short_data.building.vav_names
    t = hot.table.iloc[:-1]
    m = t[[f"m_{b}" for b in vavs]].to_numpy()
    rise = t[[f"Td_{b}" for b in vavs]].to_numpy() - t[["T_supply"]].to_numpy()
    assert_allclose(rise, 10.0, rtol=0, atol=1e-9)
    expected = float(np.sum(m * CP_AIR * rise) * 900.0 / 3.6e6)
    assert_allclose(hot.summary["heating_kWh"], expected, rtol=1e-12, atol=0)  # [kWh]
    assert "Td_" + vavs[0] not in runs[None].table  # no command, no column


def test_rule_heats_with_a_vav_reheat_sequence(plant_fmu, short_data):
    span = day_span(short_data)
    rule = run_cosim(plant_fmu, short_data, RuleController(), band=BAND, **span)
    old = run_cosim(plant_fmu, short_data, AirflowOnlyRule(), band=BAND, **span)
    b = short_data.building
    t = rule.table.iloc[:-1]
    m = t[[f"m_{v}" for v in b.vav_names]].to_numpy()
    Td = t[[f"Td_{v}" for v in b.vav_names]].to_numpy()
    Ts = t[["T_supply"]].to_numpy()
    m_min = np.array([v.m_min for v in b.vavs])
    heating = Td > Ts + 1e-9
    assert heating.mean() > 0.3  # the day needs heat
    assert np.all(m[heating] == np.broadcast_to(m_min, m.shape)[heating])  # reheat only at minimum airflow
    assert np.all(Td >= Ts - 1e-12) and np.all(Td <= DEFAULT_T_DISCHARGE_MAX + 1e-12)  # supply .. limit
    assert rule.summary["heating_kWh"] > 0.0 and rule.summary["controller_stats"]["heating_box_steps"] > 0
    # the old rule can only add (cold) air: the band is out of reach; the sequence holds it far better
    assert rule.summary["comfort_violation_Kh"] < 0.35 * old.summary["comfort_violation_Kh"]
    assert old.summary["heating_kWh"] == 0.0


# ---------------------------------------------------------------------------
# MPC deciding the reheat (harness.mpc.heating)
# ---------------------------------------------------------------------------
def test_model_a_heat_gain_from_its_airflow_gain(short_data):
    """Model A knows only the airflow gain B [K/step per kg/s]; a kW of reheat is B / (c_p ΔT_ref) with
    ΔT_ref the data's median supply-zone difference, and the groups are each zone's boxes."""
    from harness.mpc.heating import discharge_commands, heat_plan
    from hvacfmu.models.datadriven import fit_zones

    model = fit_zones(short_data)
    b = short_data.building
    vavs = b.vav_names
    frame = short_data.frame
    heated, plan, names = heat_plan(model, b, vavs, vavs, np.full(len(vavs), 35.0), frame)
    dT = np.nanmedian(frame[["T_supply"]].to_numpy() - frame[[f"T_{z}" for z in model.measured_zones]].to_numpy())
    assert_allclose(plan.G, np.asarray(model.B) * 1000.0 / (CP_AIR * dT), rtol=1e-12, atol=0)
    assert np.all(np.diag(plan.G) > 0.0)  # reheat warms its own zone
    assert [sorted(vavs[i] for i in g) for g in plan.groups] == [sorted(v.name for v in b.vavs_of(z)) for z in names]
    eq = heated.equations()
    assert eq.inputs[-len(names) :] == tuple(f"h_{z}" for z in names)
    # the plan's reheat at minimum airflow: h_max reached exactly at the heating limit
    m_min = np.array([v.m_min for v in b.vavs])
    Td = discharge_commands(plan, plan.limits(14.0), m_min, 14.0, np.arange(len(vavs)))
    assert_allclose(Td, 35.0, rtol=0, atol=1e-9)
    assert_allclose(discharge_commands(plan, np.zeros(len(names)), m_min, 14.0, [0, 1]), 14.0, rtol=0, atol=0)


def test_mpc_heats_through_discharge_air(plant_fmu, short_data):
    """Model A's MPC on the plant FMU with a band that needs heat: it decides the discharge air (between
    the supply air and the limit) and holds the band far better than the same MPC with airflow only."""
    from harness.cosim import make_controller
    from hvacfmu.models.datadriven import fit_zones

    model = fit_zones(short_data)
    span = day_span(short_data)
    runs = {
        heating: run_cosim(
            plant_fmu,
            short_data,
            make_controller("mpc", model, short_data.building, {"horizon": 12, "heating": heating}),
            model=model,
            band=BAND,
            **span,
        )
        for heating in (True, False)
    }
    hot, cold = runs[True], runs[False]
    assert hot.summary["controller_stats"]["failures"] == 0
    vavs = short_data.building.vav_names
    t = hot.table.iloc[:-1]
    Td, Ts = t[[f"Td_{v}" for v in vavs]].to_numpy(), t[["T_supply"]].to_numpy()
    assert np.all(Td >= Ts - 1e-12) and np.all(Td <= DEFAULT_T_DISCHARGE_MAX + 1e-9)
    assert hot.summary["heating_kWh"] > 0.0 and cold.summary["heating_kWh"] == 0.0
    assert hot.summary["comfort_violation_Kh"] < 0.25 * cold.summary["comfort_violation_Kh"]
    assert f"Td_{vavs[0]}" not in cold.table


def test_mpc_heats_with_a_model_that_reads_the_discharge_air(plant_fmu, short_data):
    """A model fitted where the discharge air ``Td_<vav>`` is measured (Model A's delivered-heat form, the
    default fit of every reheat building; Model B likewise) reads each box's inlet at ``Td_<vav>``. The MPC's
    reheat acts through that inlet's coefficient (a kW is ``beta`` of the box's zone), and on a plant that takes
    discharge commands the preview replaces the data's recorded ``Td`` (the building's own reheat, never applied
    to the plant) with the supply air. Before: refused ("needs the model's supply air input 'T_supply'") for
    Model A, "not a warming one" for Model B (fleet sweep s10, b000), and with ``heating=0`` the model silently
    previewed the recorded reheat."""
    from harness.cosim import make_controller
    from harness.mpc.heating import heat_plan
    from hvacfmu.models.datadriven import fit_zones

    vavs = short_data.building.vav_names
    frame = short_data.frame.assign(**{f"Td_{v}": short_data.frame["T_supply"] for v in vavs})
    model = fit_zones(dataclasses.replace(short_data, frame=frame), heat="delivered", open_loop=False)
    for v in vavs:
        frame[f"Td_{v}"] = frame["T_supply"] + 10.0  # the run's data: a recorded reheat the plant never gets
    data = dataclasses.replace(short_data, frame=frame)
    assert model.inlets == tuple(f"Td_{v}" for v in vavs)
    _, plan, names = heat_plan(model, data.building, vavs, vavs, np.full(len(vavs), 35.0), frame)
    zone_of = {v.name: v.zone for v in data.building.vavs}
    rows = list(model.outputs)
    assert names == list(vavs) and np.all(model.beta > 0.0)
    for i, v in enumerate(vavs):
        assert_allclose(plan.G[rows.index(zone_of[v]), i], model.beta[rows.index(zone_of[v])], rtol=1e-9)
    span = day_span(data)
    span["stop"] = span["start"] + pd.Timedelta(hours=3)  # the night: heat needed (21 boxes + 21 reheats)
    ctrl = make_controller("mpc", model, data.building, {"horizon": 6})
    run = run_cosim(plant_fmu, data, ctrl, model=model, band=BAND, **span)
    assert sorted(ctrl.replaced_inlets) == sorted(f"Td_{v}" for v in vavs)
    for col in ctrl.replaced_inlets:
        assert_allclose(ctrl.V[:, list(model.disturbances).index(col)], ctrl._T_supply, rtol=0, atol=0)
    assert run.summary["controller_stats"]["failures"] == 0
    assert run.summary["heating_kWh"] > 0.0


def test_mpc_runs_the_diagnosis_control_model_whose_reheat_is_read_through_the_discharge_air(plant_fmu, short_data):
    """``diagnose --control-output`` on a reheat building finds a zone's reheat through its discharge air: a term
    ``coef * Qrh_<zone>`` whose disturbance (``Σ m c_p (Td - T_supply)`` [kW]) the model derives from the frame.
    ``cosim --controller mpc`` on the plant refused that model ("the run's data lack disturbance column(s)
    ['Qrh_W'] that the model needs", round 2 of fleet sweep s10, both emulated reheat buildings). Now the preview
    derives it, 0 where the plant's boxes take this controller's discharge commands (the recorded reheat never
    reaches the plant), and the zone's reheat acts through the measured ``coef`` [K/step per kW]; a coefficient
    at its bound 0 keeps the airflow gain's scaled heat gain (else the zone could not be heated)."""
    from harness.cosim import make_controller
    from harness.mpc.heating import heat_plan, reheat_disturbances
    from hvacfmu.models.causes.reheat import Reheat
    from hvacfmu.models.datadriven import fit_zones
    from hvacfmu.models.extended import ExtendedModel

    vavs = short_data.building.vav_names
    base = fit_zones(short_data, heat="airflow", open_loop=False)
    z0, z1 = base.outputs[0], base.outputs[1]
    model = ExtendedModel(
        base, (Reheat(zone=z0, coef=0.05, variant="discharge"), Reheat(zone=z1, coef=0.0, variant="discharge"))
    )
    frame = short_data.frame.assign(**{f"Td_{v}": short_data.frame["T_supply"] + 10.0 for v in vavs})
    data = dataclasses.replace(short_data, frame=frame)
    assert f"Qrh_{z0}" in model.disturbances and f"Qrh_{z0}" not in frame
    recorded = reheat_disturbances(model, frame)[f"Qrh_{z0}"]
    assert np.nanmin(recorded) > 0.0  # the data's reheat, for a run whose boxes take no discharge command
    assert np.all(reheat_disturbances(model, frame, vavs)[f"Qrh_{z0}"] == 0.0)
    _, plan, names = heat_plan(model, data.building, vavs, vavs, np.full(len(vavs), 35.0), frame)
    rows = list(model.outputs)
    assert plan.G[rows.index(z0), 0] == pytest.approx(0.05)
    assert plan.G[rows.index(z1), 1] > 0.0  # coef 0: the airflow's heat gain, not a refusal
    span = day_span(data)
    span["stop"] = span["start"] + pd.Timedelta(hours=3)
    ctrl = make_controller("mpc", model, data.building, {"horizon": 6})
    run = run_cosim(plant_fmu, data, ctrl, model=model, band=BAND, **span)
    assert np.all(ctrl.V[:, list(model.disturbances).index(f"Qrh_{z0}")] == 0.0)
    assert run.summary["controller_stats"]["failures"] == 0
    assert run.summary["heating_kWh"] > 0.0


def test_mpc_on_the_plant_previews_no_recorded_reheat_signal_for_a_commanded_box(plant_fmu, short_data):
    """The diagnosis of a reheat building can take a box's recorded reheat signal ``rh_<vav>`` as an input
    (``unused_input``: round 2 of fleet sweep s10, building B, ``rh_VAV_NW_1`` at 1.70 K/step per unit). On a plant
    whose boxes take this controller's discharge commands the recorded signal never reaches the plant, as the
    recorded ``Td``: the preview held it at the data's values. Now 0 for a commanded box."""
    from harness.cosim import make_controller
    from hvacfmu.models.causes.unused_input import UnusedInput
    from hvacfmu.models.datadriven import fit_zones
    from hvacfmu.models.extended import ExtendedModel

    vavs = short_data.building.vav_names
    base = fit_zones(short_data, heat="airflow", open_loop=False)
    box = vavs[0]
    model = ExtendedModel(base, (UnusedInput(zone=base.outputs[0], column=f"rh_{box}", coef=0.5),))
    frame = short_data.frame.assign(**{f"rh_{box}": 0.8})
    data = dataclasses.replace(short_data, frame=frame)
    span = day_span(data)
    span["stop"] = span["start"] + pd.Timedelta(hours=2)
    ctrl = make_controller("mpc", model, data.building, {"horizon": 4})
    run = run_cosim(plant_fmu, data, ctrl, model=model, band=BAND, **span)
    assert f"rh_{box}" in ctrl.replaced_inlets
    assert np.all(ctrl.V[:, list(model.disturbances).index(f"rh_{box}")] == 0.0)
    assert run.summary["controller_stats"]["failures"] == 0


def test_mpc_heat_plan_warns_of_a_zone_it_will_barely_heat(short_data):
    """Building B of fleet sweep s10 round 2: the diagnosis's control model gives zone E a reheat gain of 1.2e-6
    K/step per kW (the airflow gain of its boxes, not identifiable in the fit, scaled into a heat gain), 1/10000 of
    the others'; the MPC left E 128 K*h below the band in two days without a word. Now a warning names the zone."""
    from harness.mpc.heating import heat_plan
    from hvacfmu.models.causes.reheat import Reheat
    from hvacfmu.models.datadriven import fit_zones
    from hvacfmu.models.extended import ExtendedModel

    vavs = short_data.building.vav_names
    base = fit_zones(short_data, heat="airflow", open_loop=False)
    z = base.outputs[0]
    frame = short_data.frame.assign(**{f"Td_{v}": short_data.frame["T_supply"] + 10.0 for v in vavs})
    weak = ExtendedModel(base, (Reheat(zone=z, coef=1e-7, variant="discharge"),))
    with pytest.warns(HvacfmuWarning, match=rf"reheat gain of {z} \(1e-07 K/step per kW\) is below 5%"):
        heat_plan(weak, short_data.building, vavs, vavs, np.full(len(vavs), 35.0), frame)
    with warnings.catch_warnings():
        warnings.simplefilter("error", HvacfmuWarning)
        heat_plan(base, short_data.building, vavs, vavs, np.full(len(vavs), 35.0), frame)
