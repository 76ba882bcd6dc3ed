"""Diagnosis: show what a model gets wrong, name the physical cause, extend the model, measure the gain.

``diagnose(dataset, model=None, plots=None, progress=True) -> DiagnosisReport``

Layers: :mod:`.residuals` (one-step and 24-hour residuals, whiteness, breakdowns),
:mod:`.design` (signals, regressors, the joint refit), :mod:`.candidates` (the
catalogue of causes and their evidence), :mod:`.selection` (LR/BIC test, held-out
gain, forward selection), :mod:`.report` (text, JSON schema ``hvacfmu.diagnosis/1``)
and :mod:`.plots` (figures, matplotlib Agg).

Cause ids: ``solar_gain``, ``supply_air_bilinear``, ``zone_coupling``,
``thermal_mass``, ``internal_gain_schedule``, ``actuation_delay``, ``reheat``,
``unused_input``, ``wind_infiltration``, ``sensor_offset``, ``held_setpoint`` (:data:`CAUSES`).
"""

from ..models.extended import CAUSES
from .pipeline import diagnose
from .report import SCHEMA, DiagnosisReport

__all__ = ["CAUSES", "SCHEMA", "DiagnosisReport", "diagnose"]
