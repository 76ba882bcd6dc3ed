import pandas as pd
import pytest

from hvacfmu.building import building_from_dict, load_building
from hvacfmu.errors import BuildingError


def test_roundtrip_toml(tmp_path, small_building):
    path = small_building.save(tmp_path / "b.toml")
    b = load_building(path)
    assert b.zone_names == ("A", "B")
    assert b.vav_names == ("V1", "V2", "V3")
    assert b.adjacency_pairs() == (("A", "B"),)
    assert b.zone_vav_matrix().tolist() == [[1, 1, 0], [0, 0, 1]]
    assert b.sha256 is not None and len(b.sha256) == 64


@pytest.mark.parametrize(
    "day, season",
    [
        ("2025-09-01", "fall"),
        ("2025-12-15", "fall"),
        ("2025-12-16", "winter"),
        ("2026-01-25", "winter"),
        ("2026-01-26", "spring"),
        ("2026-05-15", "spring"),
        ("2026-05-16", "summer"),
        ("2026-08-31", "summer"),
    ],
)
def test_default_seasons(small_building, day, season):
    assert small_building.season_of(pd.Timestamp(day)) == season


def _mutate(d, path, value):
    target = d
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return d


@pytest.mark.parametrize(
    "path, value, message",
    [
        (("zones", 0, "adjacent"), ["X"], "adjacent zone 'X'"),
        (("vavs", 2, "zone"), "Nowhere", "serves zone 'Nowhere'"),
        (("zones", 1, "area"), -3.0, "area must be > 0"),
        (("timezone",), "Mars/Olympus", "not a known IANA time zone"),
        (("vavs", 0, "m_max"), 0.01, "m_min <= m_max"),
        (("zones", 0, "facades"), [{"orientation": "NE"}], "not one of N/E/S/W"),
        (("seasons",), [{"name": "all", "start": "01-01", "end": "06-30"}], "belongs to no season"),
    ],
)
def test_bad_building(small_building_dict, path, value, message):
    with pytest.raises(BuildingError, match=message):
        building_from_dict(_mutate(small_building_dict, path, value))


def test_all_problems_reported_together(small_building_dict):
    d = small_building_dict
    d["zones"][0]["adjacent"] = ["X"]
    d["vavs"][2]["zone"] = "Nowhere"
    with pytest.raises(BuildingError) as info:
        building_from_dict(d)
    msg = str(info.value)
    assert "adjacent zone 'X'" in msg and "serves zone 'Nowhere'" in msg and "zone B: no VAV box" in msg


def test_bad_toml(tmp_path):
    p = tmp_path / "b.toml"
    p.write_text("name = [unclosed")
    with pytest.raises(BuildingError, match="not valid TOML"):
        load_building(p)
    with pytest.raises(BuildingError, match="does not exist"):
        load_building(tmp_path / "missing.toml")


# --------------------------------------------------------------------------- air handlers (issue 13)
def _two_ahus(d):
    d["ahus"] = [{"name": "AHU1", "T_supply_max": 35.0}, {"name": "AHU2", "columns": {"T_supply": "AHU-2 SAT"}}]
    for v, a in zip(d["vavs"], ("AHU1", "AHU1", "AHU2")):
        v["ahu"] = a
    return d


def test_air_handlers_map_boxes_and_columns(tmp_path, small_building_dict):
    b = building_from_dict(_two_ahus(small_building_dict))
    assert b.ahu_names == ("AHU1", "AHU2")
    assert b.ahu_of("V1").name == "AHU1" and b.ahu_of("V3").name == "AHU2"
    assert b.ahu_of("V1").T_supply_max == 35.0 and b.ahu_of("V3").T_supply_max is None
    assert [b.supply_column(v) for v in b.vav_names] == ["T_supply_AHU1", "T_supply_AHU1", "T_supply_AHU2"]
    assert b.column_for("T_supply_AHU2") == "AHU-2 SAT" and b.column_for("T_supply_AHU1") == "T_supply_AHU1"
    exp = b.expected_columns()
    assert exp["T_supply_AHU1"] and exp["T_supply_AHU2"] and not exp["T_supply"]
    assert exp["Td_V1"] is False and exp["rh_V3"] is False
    again = load_building(b.save(tmp_path / "b.toml"))
    assert again.ahus == b.ahus and again.vavs == b.vavs


def test_without_air_handlers_one_implicit_unit(small_building):
    assert small_building.ahus == ()
    assert small_building.ahu_of("V2") is None
    assert small_building.supply_column("V2") == "T_supply"
    assert small_building.expected_columns()["T_supply"] is True


@pytest.mark.parametrize(
    "mutate, message",
    [
        (
            lambda d: d["vavs"][0].update(ahu="AHU9"),
            r"VAV V1: ahu 'AHU9' is not a declared air handler \(declared units are AHU1, AHU2\)",
        ),
        (lambda d: d["vavs"][0].pop("ahu"), r"VAV V1: no 'ahu' although \[\[ahus\]\] are declared"),
        (lambda d: d["vavs"][2].update(ahu="AHU1"), r"air handler AHU2: no VAV box names it"),
        (lambda d: d["ahus"].append({"name": "AHU1"}), r"air handler name 'AHU1' is used more than once"),
        (lambda d: d["ahus"][0].update(T_supply_max=95.0), r"T_supply_max = 95 °C is not a plausible .* °F"),
        (
            lambda d: d["ahus"][0].update(T_supply_max=True),
            r"ahus\[0\] \(AHU1\)\.T_supply_max \[°C\]: expected a number, got True",
        ),
        (lambda d: d["ahus"][1].update(columns={"T_mixed": "x"}), r"unknown quantity 'T_mixed'"),
        (lambda d: d.pop("ahus"), r"VAV V1: ahu 'AHU1' is not a declared air handler \(no \[\[ahus\]\] are declared\)"),
    ],
)
def test_bad_air_handlers(small_building_dict, mutate, message):
    d = _two_ahus(small_building_dict)
    mutate(d)
    with pytest.raises(BuildingError, match=message):
        building_from_dict(d)


# --------------------------------------------------------------------------- wrong types (issue 17)
@pytest.mark.parametrize(
    "mutate, message",
    [
        (lambda d: d["zones"][0].update(area=True), r"zones\[0\] \(A\)\.area: expected a number, got True \(bool\)"),
        (
            lambda d: d["zones"][0].update(volume="300"),
            r"zones\[0\] \(A\)\.volume: expected a number, got '300' \(str\)",
        ),
        (
            lambda d: d["vavs"][0].update(m_max=float("inf")),
            r"vavs\[0\] \(V1\)\.m_max \[kg/s\]: expected a finite number",
        ),
        (lambda d: d.update(zones=["A", "B"]), r"zones\[0\]: expected a table .* got 'A' \(str\)"),
        (lambda d: d.update(vavs="V1"), r"vavs: expected an array of tables"),
        (lambda d: d["zones"][0].update(adjacent="B"), r"zones\[0\] \(A\)\.adjacent: expected a list of names"),
        (lambda d: d.update(latitude=False), r"latitude \[deg\]: expected a number, got False"),
        (lambda d: d["vavs"][0].update(m_max=0.0, m_min=0.0), r"VAV V1: m_max must be > 0 kg/s"),
        (lambda d: d["vavs"][0].update(m_min=0.7), r"VAV V1: need 0 <= m_min <= m_max, got m_min=0.7, m_max=0.6"),
        (lambda d: d["vavs"][0].update(m_max=400.0), r"VAV V1: m_max = 400 kg/s is more than any VAV box"),
        (lambda d: d.update(columns={"T_A": "room", "T_B": "room"}), r"T_A, T_B all map to the file column 'room'"),
        (lambda d: d.update(columns={"T_A": 3}), r"columns: expected a table of text values"),
        (lambda d: d.update(columns={"T_A": "T_B"}), r"T_A, T_B all map to the file column 'T_B'"),
        (lambda d: d.update(data_timezone="Europe/Nowhere"), r"data_timezone 'Europe/Nowhere' is not a known IANA"),
        (lambda d: d["zones"][0].update(name="supply"), r"zone name 'supply' is reserved"),
        (lambda d: d["vavs"][0].update(zone=1), r"vavs\[0\] \(V1\)\.zone: expected text, got 1 \(int\)"),
    ],
)
def test_wrong_types_and_values_are_named(small_building_dict, mutate, message):
    mutate(small_building_dict)
    with pytest.raises(BuildingError, match=message):
        building_from_dict(small_building_dict)


def test_a_large_zones_large_unit_is_not_taken_for_a_unit_error(small_building_dict):
    # the DOE supermarket's sales area (16 000 m3) has one packaged unit of 11.4 kg/s, 2 air changes an hour: the
    # building file refused it as "more than any VAV box delivers ... is the value in kg/s?" after a year of EnergyPlus
    d = small_building_dict
    d["zones"][0].update(area=2600.0, volume=16000.0)
    d["vavs"][0].update(m_min=0.0, m_max=11.4)
    assert building_from_dict(d).vavs[0].m_max == 11.4
    # the same unit in a 300 m3 room would renew its air 114 times an hour: a unit error, still refused
    d["zones"][0].update(area=100.0, volume=300.0)
    with pytest.raises(BuildingError, match=r"VAV V1: m_max = 11.4 kg/s .* zone A \(300 m3\) 114 times an hour"):
        building_from_dict(d)


def test_wrong_types_in_toml_file_name_the_file(tmp_path):
    p = tmp_path / "b.toml"
    p.write_text('name = "x"\nlatitude = 1.0\nlongitude = 2.0\ntimezone = "UTC"\nzones = ["A"]\nvavs = ["V"]\n')
    with pytest.raises(BuildingError) as info:
        load_building(p)
    msg = str(info.value)
    assert str(p) in msg and "zones[0]: expected a table" in msg and "vavs[0]: expected a table" in msg
