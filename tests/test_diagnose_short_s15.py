"""``diagnose`` on data whose seasons have one training week each: refused naming the seasons, weeks and fix (it
crashed in the least squares with ``LinAlgError: Singular matrix`` before); a season with one training week beside
one with two is named in the notes."""

from __future__ import annotations

import types

import pandas as pd
import pytest

from hvacfmu.diagnosis.pipeline import _require_two_training_weeks
from hvacfmu.errors import DataError


def test_four_winter_weeks_over_two_seasons_are_refused_naming_them(winter_dataset):
    import hvacfmu

    seasons = [(w.season, w.train) for w in winter_dataset.weeks]
    assert seasons == [("winter", True), ("winter", False), ("spring", True), ("spring", False)]
    with pytest.raises(DataError, match=r"no season has two training weeks") as err:
        hvacfmu.diagnose(winter_dataset, progress=False)
    msg = str(err.value)
    assert "winter: 1 (2026-01-12)" in msg and "spring: 1 (2026-01-26)" in msg
    assert "measurements" in msg and "Fix: give more weeks" in msg


def _weeks(*spec):
    start = pd.Timestamp("2026-01-05", tz="UTC")
    return types.SimpleNamespace(
        source="m.csv",
        weeks=[
            types.SimpleNamespace(season=s, train=t, start=start + pd.Timedelta(days=7 * i))
            for i, (s, t) in enumerate(spec)
        ],
    )


def test_a_season_with_one_training_week_beside_one_with_two_is_noted():
    notes: list = []
    _require_two_training_weeks(_weeks(("winter", True), ("spring", True), ("spring", True), ("spring", False)), notes)
    assert len(notes) == 1 and "season winter has one training week (2026-01-05)" in notes[0]
    notes = []
    _require_two_training_weeks(_weeks(("winter", True), ("winter", True), ("winter", False)), notes)
    assert notes == []
    with pytest.raises(DataError, match=r"m.csv: no season has two training weeks .*training weeks by season: none"):
        _require_two_training_weeks(_weeks(("winter", False)), [])
