"""Discharge-air columns ``Td_<vav>`` exchanged between boxes of two zones (red team s15/s16
``discharge_swapped_no_rh``: silent, model +14 % worse on the clean data). README "What gets refused"."""

from __future__ import annotations

import warnings

import pandas as pd

from hvacfmu.data import boxmap, check, prepare
from hvacfmu.errors import HvacfmuWarning

#: The reheat case of tests/test_control_gain.py (same cache key): three weeks, Td_<vav> at every box.
REHEAT = {"weeks": 3, "seed": 0, "hvac": "reheat", "start": "2025-11-03T00:00:00"}


def _read(path):
    return pd.read_parquet(path) if str(path).endswith(".parquet") else pd.read_csv(path)


def test_discharge_columns_swapped_between_zones_are_flagged(tmp_path):
    """Td_VAV_C_1 and Td_VAV_NW_1 exchanged (core and north-west; lead 73 units), no rh_ columns: each box's heat computed with the other box's
    column explains its own zone better than with its own, both ways; check exits 3 naming both columns and the
    [columns] fix. The clean export has no such message."""
    from hvacfmu.emulator import cached_dataset

    paths = cached_dataset(**REHEAT)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        ds = prepare(paths.measurements, paths.building)
    assert boxmap.check_discharge_swaps(ds.frame, ds.building) == []
    f = _read(paths.measurements)
    f = f.assign(Td_VAV_C_1=f["Td_VAV_NW_1"], Td_VAV_NW_1=f["Td_VAV_C_1"])
    f = f.drop(columns=[c for c in f.columns if c.startswith("rh_")])
    path = tmp_path / "swapped.csv"
    f.to_csv(path, index=False)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", HvacfmuWarning)
        rep = check(path, paths.building)
    assert rep.exit_code == 3
    found = [w for w in rep.warnings if "(Td_VAV_C_1)" in w]
    assert len(found) == 1, rep.warnings
    msg = found[0]
    assert "columns 'Td_VAV_NW_1' (Td_VAV_NW_1) and 'Td_VAV_C_1' (Td_VAV_C_1) look swapped" in msg
    assert '[columns] table (Td_VAV_NW_1 = "Td_VAV_C_1", Td_VAV_C_1 = "Td_VAV_NW_1")' in msg
    assert "discharge columns swapped" in str(rep)  # the attention line


def test_one_box_preferring_another_column_is_not_a_swap(monkeypatch):
    """A zone fed by transfer air from another (EnergyPlus kitchen and dining room) follows that zone's discharge
    air: one direction is not a swap; both directions are."""
    one = boxmap.DischargePairEvidence(
        own={"K": 20.0, "D": 150.0}, other={"K": {"D": 300.0}, "D": {"K": 40.0}}, rows=2000
    )
    both = boxmap.DischargePairEvidence(
        own={"K": 20.0, "D": 30.0}, other={"K": {"D": 300.0}, "D": {"K": 140.0}}, rows=2000
    )

    class B:
        def column_for(self, c):
            return c

        def vav(self, v):
            return type("V", (), {"zone": {"K": "Kitchen", "D": "Dining"}[v]})

    monkeypatch.setattr(boxmap, "discharge_pair_evidence", lambda f, b: one)
    assert boxmap.check_discharge_swaps(None, B()) == []
    monkeypatch.setattr(boxmap, "discharge_pair_evidence", lambda f, b: both)
    assert "columns 'Td_K' (Td_K) and 'Td_D' (Td_D) look swapped" in boxmap.check_discharge_swaps(None, B())[0]
