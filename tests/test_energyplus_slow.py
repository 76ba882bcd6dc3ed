"""EnergyPlus, slow tier: a year of two prototypes through the whole pipeline, and EnergyPlus hosting FMU + MPC."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pandas as pd
import pytest

pytest.importorskip("pyenergyplus")

from hvacfmu.data import prepare
from hvacfmu.energyplus import cached_export
from hvacfmu.energyplus.checks import airflow_identifiability, margins_table
from hvacfmu.energyplus.run import CallbackError

pytestmark = pytest.mark.slow

VAV_OFFICE = ("ASHRAE901_OfficeMedium_STD2019_Denver", "mid")  # VAV with electric reheat, one floor of five zones
PACKAGED = ("ASHRAE901_RestaurantFastFood_STD2019_Denver", None)  # two packaged single-zone units
SMALL_OFFICE = "ASHRAE901_OfficeSmall_STD2019_Denver"


def _fit_evaluate(prototype, floor, kinds):
    from hvacfmu.evaluation import evaluate
    from hvacfmu.fitting import fit

    paths = cached_export(prototype, floor=floor, weeks=None)  # the options of bench_energyplus.py (one cache)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        models = {k: fit(ds, k, progress=False) for k in kinds}
        res = evaluate(list(models.values()), ds, names=list(models))
    return ds, models, res


@pytest.fixture(scope="module")
def vav_office():
    return _fit_evaluate(*VAV_OFFICE, ("lumped", "zones", "physics"))


@pytest.fixture(scope="module")
def packaged():
    return _fit_evaluate(*PACKAGED, ("lumped", "zones", "physics"))


def _report(name, res):
    table = margins_table(res)
    print(f"\n{name}\n{table.to_string(float_format=lambda x: f'{x:.3f}')}")
    return table


@pytest.mark.parametrize("which", ["vav_office", "packaged"])
def test_pipeline_runs_end_to_end(which, request):
    ds, _models, res = request.getfixturevalue(which)
    assert len(ds.weeks) >= 50 and len(ds.test_weeks()) >= 4
    assert {s.name for s in res.scores} == {"lumped", "zones", "physics"}
    table = _report(which, res)
    assert np.isfinite(table["rms"]).all()


@pytest.mark.parametrize(
    "which, kind",
    [
        ("vav_office", "lumped"),
        ("vav_office", "zones"),
        ("vav_office", "physics"),
        ("packaged", "lumped"),
        ("packaged", "zones"),
        ("packaged", "physics"),
    ],
)
def test_every_model_beats_persistence_and_time_of_week(which, kind, request):
    """Issue 13 p.8: every model kind beats both baselines in every season (mean over zones)."""
    _, _, res = request.getfixturevalue(which)
    table = margins_table(res).loc[kind]
    losing = table[(table["margin_pers_%"] <= 0) | (table["margin_tow_%"] <= 0)]
    assert losing.empty, f"{which}/{kind} loses in: \n{losing.to_string()}"


def test_closed_loop_airflow_gains_are_detected(vav_office):
    """The zones model fitted on closed-loop EnergyPlus data: its airflow gains are checked against physics."""
    ds, models, _ = vav_office
    lines = airflow_identifiability(models["zones"], ds.building)
    print("\n".join(lines))
    assert lines[0].startswith("airflow identifiability:")
    assert len(lines) == 1 + len(ds.building.zones)
    m = models["zones"]
    # the report agrees with the fitted numbers: flagged exactly where the gain is below step / C_max
    cap = np.array([30 * 1.2 * 1005.0 * ds.building.zone(z).volume for z in m.outputs])  # [J/K]
    if getattr(m, "beta", None) is not None:  # delivered heat [K/step per kW]
        gains, g_min = np.abs(m.beta), 1000.0 * 900.0 / cap
    else:  # airflow [K/(kg/s)/step] with a 2 K supply-to-zone difference
        gains, g_min = np.abs(np.diag(m.B)), 1005.0 * 2.0 * 900.0 / cap
    expected = {z for z, g, lo in zip(m.outputs, gains, g_min) if g < lo}
    flagged = {line.split(":")[0] for line in lines[1:] if "NOT IDENTIFIED" in line}
    assert flagged == expected
    assert f"{len(expected)} of {len(m.outputs)}" in lines[0]


# --------------------------------------------------------------------------- EnergyPlus as host
@pytest.fixture(scope="module")
def host_setup(tmp_path_factory):
    from hvacfmu.fitting import fit
    from hvacfmu.fmu import export_fmu

    paths = cached_export(SMALL_OFFICE, start="05-01", weeks=12)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ds = prepare(paths.measurements, paths.building)
        model = fit(ds, "zones", progress=False)
    out = tmp_path_factory.mktemp("host")
    fmu = export_fmu(model.save(out / "zones.json"), out / "zones.fmu", timezone=ds.building.timezone)
    lo = pd.Timestamp("2017-07-10").tz_localize(ds.building.timezone)  # a Monday
    frame = ds.frame[(ds.frame.index >= lo) & (ds.frame.index < lo + pd.Timedelta(days=2))]
    return ds, model, fmu, frame


def test_energyplus_hosts_fmu_and_mpc(host_setup):
    from harness.energyplus_host import HostSettings, compare, run_host
    from harness.mpc import cosim_controller

    ds, model, fmu, frame = host_setup
    ref = run_host(SMALL_OFFICE, ds.building, frame, fmu=fmu)
    ctl = run_host(
        SMALL_OFFICE,
        ds.building,
        frame,
        fmu=fmu,
        model=model,
        controller=cosim_controller(model, ds.building, horizon=16),
    )
    print("\n" + compare(ref, ctl))
    for r in (ref, ctl):
        assert len(r.table) == len(frame) == 192
        assert (r.table.index == frame.index).all()
        zones = ds.building.zone_names
        assert np.isfinite(r.table[[f"fmu_T_{z}" for z in zones]].to_numpy()).all()
        assert r.summary["energy_kWh"] > 0
    # the reference run writes nothing; the MPC run writes every occupied step, and EnergyPlus used each value
    assert ref.summary["setpoints_sent"] == 0
    settings = HostSettings()
    n_occ = sum(settings.is_occupied(t + pd.Timedelta(minutes=15)) for t in frame.index[:-1])
    assert ctl.summary["setpoints_sent"] == n_occ * len(ds.building.zones)
    assert ctl.mismatches == []
    sent = ctl.table[[c for c in ctl.table.columns if c.startswith("sp_cool_sent_")]]
    seen = ctl.table[[c.replace("sent", "seen") for c in sent.columns]]
    pairs = np.column_stack([sent.to_numpy()[:-1].ravel(), seen.to_numpy()[1:].ravel()])
    pairs = pairs[np.isfinite(pairs[:, 0])]
    assert len(pairs) == ctl.summary["setpoints_sent"] - int(np.isfinite(sent.to_numpy()[-1]).sum())
    np.testing.assert_allclose(pairs[:, 1], pairs[:, 0], rtol=0, atol=1e-6)  # [K] step by step
    lo, hi = settings.band
    assert np.nanmin(sent.to_numpy()) >= lo + 0.5 - 1e-9 and np.nanmax(sent.to_numpy()) <= hi + 1e-9
    # the MPC keeps the band better than EnergyPlus's own thermostats on this building
    assert ctl.summary["violation_Kh"] < ref.summary["violation_Kh"]


def test_exception_in_the_loop_stops_energyplus(host_setup):
    from harness.energyplus_host import run_host

    ds, _model, _fmu, frame = host_setup

    class Broken:
        name = "broken"
        model = None

        def __init__(self):
            self.calls = 0

        def reset(self, context):
            pass

        def __call__(self, k, t, y, v):
            self.calls += 1
            raise RuntimeError(f"controller failed at step {k}")

    broken = Broken()
    with pytest.raises(CallbackError, match="RuntimeError: controller failed at step 1") as info:
        run_host(SMALL_OFFICE, ds.building, frame, controller=broken)
    assert broken.calls == 1 and info.value.steps_after_error == 0


def test_export_is_deterministic(tmp_path):
    from hvacfmu.energyplus import generate

    a = generate(tmp_path / "a", "restaurant_fast_food", days=2, start="07-10", fmt="csv")
    b = generate(tmp_path / "b", "restaurant_fast_food", days=2, start="07-10", fmt="csv")
    assert a.measurements.read_bytes() == b.measurements.read_bytes()
    assert a.building.read_bytes() == b.building.read_bytes()


def test_injected_equipment_heat_shows_in_the_export(tmp_path):
    """A 12 kW ElectricEquipment on a Schedule:File (given through ``files``) added with ``extra_idf`` warms its
    zone while the HVAC is off (1 January 2017 is a Sunday); the building file's zones, facades and physics tables
    do not see it (EnergyPlus's autosizing does: the boxes' limits come from the run's sizing)."""
    import tomllib

    from hvacfmu.energyplus import generate

    sched = "Schedule:File,hvacfmu_on,,{run_dir}/on.csv,1,0,8760,Comma,No,60,No;\n"
    extra = sched + "ElectricEquipment,hvacfmu_heater,Perimeter_mid_ZN_3,hvacfmu_on,EquipmentLevel,12000,,,0,0,0,x;\n"
    files = {"on.csv": "1\n" * 8760}
    base = generate(tmp_path / "base", VAV_OFFICE[0], floor=VAV_OFFICE[1], days=2)
    hot = generate(tmp_path / "hot", VAV_OFFICE[0], floor=VAV_OFFICE[1], days=2, extra_idf=extra, files=files)
    a, b = pd.read_parquet(base.measurements), pd.read_parquet(hot.measurements)
    sunday = slice(0, 96)  # local 1 January, HVAC off all day
    rise = (b["T_Perimeter_mid_ZN_3"] - a["T_Perimeter_mid_ZN_3"]).iloc[sunday]
    others = (b["T_Perimeter_mid_ZN_1"] - a["T_Perimeter_mid_ZN_1"]).iloc[sunday]
    assert rise.mean() > 3.0  # [K] 12 kW in a 569 m3 zone over a day
    assert rise.mean() > 5 * abs(others.mean())
    tables = [tomllib.loads(p.building.read_text()) for p in (base, hot)]
    for t in tables:
        t.pop("vavs")
    assert tables[0] == tables[1]
    info = json.loads(hot.info.read_text())
    assert "added ElectricEquipment 'hvacfmu_heater' (extra_idf)" in info["idf_changes"]
    assert list(info["files"]) == ["on.csv"]


@pytest.mark.parametrize(
    "prototype, floor, n_boxes",
    [("office_large", "mid", 6), ("hotel_large", "Flr_6", 10)],
)
def test_every_air_stream_of_an_exported_zone_is_in_the_data_once(prototype, floor, n_boxes, tmp_path):
    """The exported boxes' m·cp·(Td − T_zone), summed per zone, must close that zone's air heat balance.

    The 90.1 large office's mid floor is one floor simulated for ten (Zone Multiplier 10): its inlet nodes carry the
    air of all ten and its terminals are sized for ten; the export refused the building (Core_mid m_max 60 kg/s,
    "more than any VAV box delivers"). The large hotel's guest rooms get a DOAS box and a four-pipe fan coil that
    does most of the heating and cooling: the fan coil was in no column, and Room_3_Mult9_Flr_6 (x9) got nine
    rooms' DOAS air."""
    import datetime as dt

    from hvacfmu.building import load_building
    from hvacfmu.energyplus import generate, hvac
    from hvacfmu.energyplus.generate import _frame, export_probes, select_boxes
    from hvacfmu.energyplus.idf import read_idf
    from hvacfmu.energyplus.inputs import prepare_idf, read_site, resolve_prototype, resolve_weather
    from hvacfmu.energyplus.run import Probe, simulate

    paths = generate(tmp_path / "export", prototype, floor=floor, days=2, start="01-17")
    b = load_building(paths.building)
    frame = pd.read_parquet(paths.measurements)
    assert len(b.vavs) == n_boxes
    for v in b.vavs:
        assert v.m_max < 10.0, v  # [kg/s] one zone's box
        assert frame[f"m_{v.name}"].max() <= 1.05 * v.m_max, v.name

    idf_path = resolve_prototype(prototype)
    epw = resolve_weather(None, idf_path)
    site = read_site(epw)
    idf = read_idf(idf_path)
    boxes = select_boxes(hvac.air_boxes(idf), floor, None)
    assert [bx.name for bx in boxes] == list(b.vav_names)
    ahus = {}
    for bx in boxes:
        ahus.setdefault(bx.ahu, bx.supply_node)
    zones = list(dict.fromkeys(bx.zone for bx in boxes))
    prepare_idf(idf, dt.date(2017, 1, 17), dt.date(2017, 1, 18), site)
    (tmp_path / "in.idf").write_text(idf.text(), encoding="latin-1")
    probes = export_probes(boxes, ahus, zones)
    terms = {
        "sto": "Zone Air Heat Balance Air Energy Storage Rate",
        "int": "Zone Air Heat Balance Internal Convective Heat Gain Rate",
        "surf": "Zone Air Heat Balance Surface Convection Rate",
        "iz": "Zone Air Heat Balance Interzone Air Transfer Rate",
        "oa": "Zone Air Heat Balance Outdoor Air Transfer Rate",
    }
    probes += [Probe(f"{k}_{z}", var, z) for z in zones for k, var in terms.items()]
    values, times, _ = simulate(tmp_path / "in.idf", epw, tmp_path / "out", probes)
    df = _frame(values, times, probes, site, boxes, ahus)  # the export's own mapping
    for z in zones:
        temp = df[f"T_{hvac.sanitise(z)}"]
        delivered = sum(df[f"m_{bx.name}"] * 1005.0 * (df[f"Td_{bx.name}"] - temp) for bx in boxes if bx.zone == z)
        rest = df[f"sto_{z}"] - df[f"int_{z}"] - df[f"surf_{z}"] - df[f"iz_{z}"] - df[f"oa_{z}"]  # [W]
        assert rest.std() > 150, z  # [W] the zone is conditioned
        # closes within a quarter of the spread (node values are step averages); a missing fan coil or ten times
        # the air would not
        assert np.sqrt(np.mean((delivered - rest) ** 2)) < 0.25 * rest.std(), z
