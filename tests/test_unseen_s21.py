"""Session 21, issue 13: failures found running the whole pipeline on buildings and exports never used here.

See benchmarks/unseen_s21.md for the runs (DOE 2004 secondary school in Boulder weather, the 90.1 small hotel in
Golden weather, the emulator's stack4 building in the hot climate exported as °F/CFM with naive UTC times).
"""

from __future__ import annotations

import shutil

import numpy as np
import pandas as pd
import pytest
from test_fmu import zones_model

from hvacfmu.fmu_native import export_native_fmu
from hvacfmu.fmu_slave import signal_bounds


@pytest.fixture(scope="module")
def sdh():
    from hvacfmu.emulator import sdh_building

    return sdh_building(nominal=True)


def test_idle_supply_and_discharge_air_below_freezing_are_fmu_inputs():
    """An idle air handler's duct follows the outdoor air: the data and models read it, so must the FMUs."""
    for name in ("T_supply", "T_supply_AHU1", "Td_VAV_NW_1"):
        lo, hi = signal_bounds(name)
        assert lo <= -5.0 and hi == 80.0, (name, lo, hi)


@pytest.mark.skipif(shutil.which("gcc") is None, reason="needs the system C compiler gcc")
def test_native_fmu_steps_on_an_idle_winter_supply_temperature(sdh, tmp_path):
    """`cosim`'s warm-up of the DOE school (Boulder, January) fed T_supply = -4.91 °C: the FMU refused the step."""
    from test_fmu_native import Native, start_values

    model = zones_model(sdh)
    path = export_native_fmu(model, tmp_path / "zones.fmu")
    fmu = Native(path, "idle")
    try:
        fmu.init(start_values(model))
        names_in = [n for n in fmu.vr if n in ("T_out", "T_supply") or n.startswith("m_VAV_")]
        values = {"T_out": -8.0, "T_supply": -4.91}
        row = [values.get(n, 0.0) for n in names_in]  # the unit off: every box at 0 kg/s, the duct at -4.91 °C
        fmu.fmu.setReal([fmu.vr[n] for n in names_in], row)
        fmu.fmu.doStep(0.0, 900.0)
        out = fmu.fmu.getReal([fmu.vr[f"T_{z}"] for z in model.outputs])
        assert np.isfinite(out).all()
        assert not any("invalid input" in msg for _, _, msg in fmu.log)
        fmu.fmu.setReal([fmu.vr["T_supply"]], [95.0])  # still refused above the bound, naming the input
        with pytest.raises(Exception, match="error"):
            fmu.fmu.doStep(900.0, 900.0)
        assert any("invalid input value(s): T_supply=95" in msg for _, _, msg in fmu.log)
    finally:
        fmu.close()


def test_a_zone_held_at_its_setpoint_with_float_noise_is_not_a_held_sensor(tmp_path):
    """The 90.1 small hotel's front office (EnergyPlus, Golden weather) rests at 75 °F written as 23.8889, 23.889
    and 23.89 and leaves it by a jump when the schedule changes: main counted the noisy copies as distinct held
    readings and `check` exited 3 with "a held sensor? ... fix the trend log" on a simulated building. A sensor
    repeating its last (different) reading each night is still flagged."""
    from test_properties import BUILDING, base_frame, write

    from hvacfmu.building import building_from_dict
    from hvacfmu.data import load_measurements

    building = building_from_dict(BUILDING)
    frame = base_frame()
    h = frame.index.hour
    night = (h >= 20) | (h < 6)
    setpoint = frame["T_A"].copy()
    noisy = np.array([23.8889, 23.889, 23.89, 23.88889, 23.888889, 23.8889001, 23.88891, 23.8890001])
    day = (frame.index - frame.index[0] - pd.Timedelta(hours=6)).days.to_numpy()  # one number per night
    setpoint[night] = noisy[day[night] % len(noisy)]
    setpoint[~night] = frame["T_A"][~night] + 1.0
    frame["T_A"] = setpoint
    _, rep = load_measurements(write(frame, tmp_path / "m.csv", "offset"), building)
    assert not [w for w in rep.warnings if "held sensor" in w], rep.warnings
    # the same nights holding the last reading (a controller offline) are still flagged
    frame = base_frame()
    held = frame["T_A"].copy()
    held[night] = np.nan
    held = held.ffill()
    held[~night] = frame["T_A"][~night] + 1.0
    frame["T_A"] = held
    _, rep = load_measurements(write(frame, tmp_path / "h.csv", "offset"), building)
    assert any("column 'T_A': a held sensor?" in w for w in rep.warnings)


@pytest.mark.slow
def test_one_sparse_box_does_not_hide_the_holiday_judgement():
    """The stack4 export with `--fault sparse_box` (one box in 5.6 % of the rows): `check` said the training weeks
    hold "too few training workdays and Sundays to tell" whether the building closes on public holidays, while the
    same export without the fault judged its holiday ("ran as on a workday"). The day signature summed every box per
    row, so the sparse box blanked every day; it is now left out of the signature."""
    import hvacfmu as hf
    from hvacfmu.data.holidays import decide_holidays
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(weeks=8, seed=0)
    ds = hf.data.prepare(paths.measurements, paths.building)
    clean = decide_holidays(ds.frame, ds.building, ds.weeks)
    assert clean.gammas and not any("too few" in n for n in clean.notes), clean.notes
    frame = ds.frame.copy()
    box = f"m_{ds.building.vavs[0].name}"
    keep = np.zeros(len(frame), bool)
    keep[::18] = True  # about 5.6 % of the rows keep a value
    frame.loc[~keep, box] = np.nan
    sparse = decide_holidays(frame, ds.building, ds.weeks)
    assert not any("too few" in n for n in sparse.notes), sparse.notes
    assert set(sparse.gammas) == set(clean.gammas)


def test_diagnose_names_the_number_of_zones_it_fits(monkeypatch):
    """On the five-zone school pod `diagnose` said "fitting the six-zone Model A": the count is the building's."""
    import types

    import hvacfmu.fitting
    from hvacfmu.diagnosis.pipeline import _base_model

    fitted = types.SimpleNamespace(heat="airflow")
    monkeypatch.setattr(hvacfmu.fitting, "fit", lambda *a, **k: fitted)
    said: list = []
    zones = ("Corner_1", "Corner_2", "Corridor", "Mult_1", "Mult_2")
    dataset = types.SimpleNamespace(building=types.SimpleNamespace(zone_names=zones))
    model, given = _base_model(dataset, None, said.append, [])
    assert model is fitted and not given
    assert said and said[0].startswith("fitting the 5-zone Model A"), said


def test_a_sparse_box_after_interpolate_gaps_is_not_told_to_interpolate_again(tmp_path):
    """The stack4 export's sparse box (`--fault sparse_box`): `check` advised `--interpolate-gaps MINUTES (a little
    over its spacing)`; with `--interpolate-gaps 200` (its median spacing is 195 min) the box still had 22.9 % and
    `check` repeated the same advice. Now it says the gaps left are longer than what was bridged."""
    from test_properties import BUILDING, base_frame, write

    from hvacfmu.building import building_from_dict
    from hvacfmu.data.check import check

    building = building_from_dict(BUILDING)
    frame = base_frame()
    frame.loc[frame.index[len(frame) // 4] :, "m_V2"] = np.nan  # the box logs a quarter of the span
    path = write(frame, tmp_path / "m.csv", "offset")
    first = check(path, building)
    msg = next(p for p in first.problems if "'m_V2'" in p)
    assert "bridge its samples with --interpolate-gaps MINUTES" in msg
    again = check(path, building, interpolate_limit=30)
    msg = next(p for p in again.problems if "'m_V2'" in p)
    assert "--interpolate-gaps MINUTES" not in msg, msg
    assert "--interpolate-gaps 30 bridged the gaps up to 30 min and left these" in msg, msg


def test_a_season_lost_without_discharge_air_names_the_missing_input(monkeypatch):
    """The stack4 reheat export without its Td_ columns (rh_ kept): the zones model won the year against both
    baselines but lost winter to the time-of-week mean in N1 (0.171 against 0.164 K); main named only "one held-out
    week". The missing discharge air is now flagged on the model's first line and as the first likely cause."""
    import types

    import pandas as pd

    from hvacfmu.evaluation import verdict as V

    zones = [V.ZoneVerdict("zones", "N1", 0.219, 0.663, 0.227, -0.3, 1.4, 500)]
    seasons = [
        V.SeasonVerdict("zones", "N1", "winter", 0.171, 0.60, 0.164, 4, 1),
        V.SeasonVerdict("zones", "N1", "fall", 0.25, 0.70, 0.30, 5, 1),
    ]
    monkeypatch.setattr(V, "_zone_verdicts", lambda sc: zones)
    monkeypatch.setattr(V, "_season_verdicts", lambda sc: seasons)
    monkeypatch.setattr(V, "_coverage", lambda sc, ds: {"skipped": {}, "windows": {"winter": 4, "fall": 5}})
    monkeypatch.setattr(V, "season_causes", lambda *a, **k: [])
    monkeypatch.setattr(V, "_unused_columns", lambda *a, **k: [])
    monkeypatch.setattr(V, "_sparse_columns", lambda *a, **k: [])
    monkeypatch.setattr(V, "gain_profile_hint", lambda *a, **k: "")
    frame = pd.DataFrame({"T_N1": [21.0], "m_V1": [0.3], "rh_V1": [0.5], "T_supply": [13.0]})
    building = types.SimpleNamespace(vav_names=("V1",))
    dataset = types.SimpleNamespace(frame=frame, building=building, warnings=[])
    model = types.SimpleNamespace(disturbances=("T_out", "T_supply"), inputs=("m_V1",), outputs=("N1",))
    score = types.SimpleNamespace(starts=[0], name="zones")
    v = V.make_verdict([score], [model], dataset)
    assert v.missing == {"zones": ["Td_V1"]}
    lines = v.format().splitlines()
    assert lines[0].startswith("!! zones:") and "missing input: Td_V1 not measured" in lines[0], lines
    assert "!! zones: WORSE THAN THE TIME-OF-WEEK MEAN in N1 in winter 0.171 K against 0.164 K" in lines, lines
    assert v.causes["zones"][0].startswith("missing input: the boxes reheat (rh_ columns)"), v.causes


def test_cosim_names_which_of_several_air_handlers_is_off():
    """The 90.1 small hotel (four single-zone units) in `cosim`: main said "the data's air handler is off in 541 of
    672 steps" while two of its four units were (the meeting room's 539 steps, the front office's 3). With several
    units the line says some unit is off and lists each one's off steps; one unit keeps the old wording."""
    import pandas as pd

    from harness.cosim import _schedule_lines
    from harness.schedule import RunSchedule

    index = pd.date_range("2017-01-22", periods=6, freq="15min", tz="America/Denver")
    off = np.zeros((6, 4), bool)
    off[1:4, 2] = True  # the third box's unit off in 3 steps
    off[5, 3] = True
    sched = RunSchedule("schedule", off, units=("U1", "U1", "U2", "U3"))
    s = {"schedule": sched.summary(index), "steps_requested": 6}
    line = _schedule_lines(s)[0]
    assert "an air handler of the data is off in 4 of 6 steps (2 of 3 units: U2 3 steps, U3 1 step;" in line, line
    one = RunSchedule("schedule", off[:, 2:3], units=("U2",))
    line = _schedule_lines({"schedule": one.summary(index), "steps_requested": 6})[0]
    assert "the data's air handler is off in 3 of 6 steps (1 periods)" in line, line


def test_a_box_whose_heat_follows_every_zone_is_not_mapped_to_one(monkeypatch):
    """The DOE 2004 large hotel's ground floor (Boulder weather): the laundry's box (1.8-3.8 kg/s, no evidence in the
    laundry) "explained" Storage 398, Mech 254, Retail_1 161, Cafe 83 log-likelihood units; main flagged it as serving
    Storage and `check` exited 3 on a mapping EnergyPlus itself defines. A box whose evidence is spread over the
    zones follows what they share; a swapped box's evidence sits in the zone it serves, and is still flagged."""
    import types

    from hvacfmu.data import boxmap

    zones = ("Laundry", "Storage", "Mech", "Retail_1", "Cafe")
    building = types.SimpleNamespace(vav=lambda v: types.SimpleNamespace(zone={"VL": "Laundry", "VS": "Cafe"}[v]))
    ev = boxmap.BoxZoneEvidence(
        zone={
            "VL": dict(zip(zones, (0.0, 398.0, 254.0, 161.0, 83.0))),
            "VS": dict(zip(zones, (0.0, 330.0, 12.0, 0.0, 5.0))),  # VS serves Storage, mapped to Cafe
        },
        rows=35038,
        boxes=("VL", "VS"),
        zone_t={"VL": ("Storage", 0.0), "VS": ("Storage", 3.1)},
    )
    monkeypatch.setattr(boxmap, "box_zone_evidence", lambda frame, b: ev)
    notes = boxmap.check_box_zones(None, building)
    assert not any(n.startswith("box VL:") for n in notes), notes
    assert any(n.startswith("box VS:") and "zone Storage far better than those of zone Cafe" in n for n in notes)
