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
    [("2025-09-01", "fall"), ("2025-12-15", "fall"), ("2025-12-16", "winter"), ("2026-01-25", "winter"),
     ("2026-01-26", "spring"), ("2026-05-15", "spring"), ("2026-05-16", "summer"), ("2026-08-31", "summer")],
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
