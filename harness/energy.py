"""The energy of a closed-loop run, and what "at equal or lower energy" means (issue 18 point 5).

A run (:func:`harness.cosim.run_cosim`) spends energy in two ways that its summary reports:

- **fan and cooling**: the airflow the boxes take, measured by the paper's proxy
  ``Σ_k Σ_b m_b(k)²`` [(kg/s)²] (``summary["energy_proxy"]``, the quantity the MPC minimises);
- **reheat**: the heat commanded through the discharge inputs, ``Σ m c_p max(Td - T_supply, 0) Δt``
  [kWh] (``summary["heating_kWh"]``, 0 when the controller commands no discharge air).

They are not added into one number: the plant (the emulator's, or any FMU the harness runs)
has no fan curve, coil or boiler model, so any factor turning ``(kg/s)²`` into kWh would be
invented. Instead one run uses **no more energy** than another when it uses no more of
*either* (Pareto order, :meth:`EnergyUse.at_most`). A comparison "at equal or lower energy"
therefore never trades reheat against airflow.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping


@dataclasses.dataclass(frozen=True)
class EnergyUse:
    """Energy of a run: fan/cooling proxy and reheat.

    Attributes
    ----------
    airflow : float [(kg/s)²]
        ``Σ m²`` over steps and boxes (fan and cooling proxy; the paper's energy).
    reheat_kWh : float [kWh]
        Reheat commanded through the discharge air inputs.
    """

    airflow: float
    reheat_kWh: float

    @classmethod
    def of(cls, summary: Mapping) -> EnergyUse:
        """The energy of a run from its summary (:attr:`harness.cosim.CosimResult.summary`)."""
        return cls(float(summary["energy_proxy"]), float(summary.get("heating_kWh", 0.0)))

    def at_most(self, other: EnergyUse) -> bool:
        """True when this run uses no more fan/cooling energy and no more reheat than ``other``.

        The comparison is exact (no tolerance): the runs are deterministic, and "equal or
        lower" is meant literally.
        """
        return self.airflow <= other.airflow and self.reheat_kWh <= other.reheat_kWh

    def airflow_change_percent(self, base: EnergyUse) -> float:
        """Change of the fan/cooling proxy against ``base`` [%] (0 when ``base`` has none)."""
        return 100.0 * (self.airflow / base.airflow - 1.0) if base.airflow > 0 else 0.0

    def change(self, base: EnergyUse) -> str:
        """``"+1.2 % Σu², -3.0 kWh reheat"``: this run against ``base``."""
        rel = self.airflow_change_percent(base)
        return f"{rel:+.1f} % Σu², {self.reheat_kWh - base.reheat_kWh:+.1f} kWh reheat"


def frontier_gain(base: Mapping, candidates) -> dict | None:
    """The best candidate run at no more energy than ``base`` (fewest K·h), or ``None``.

    Parameters
    ----------
    base : mapping
        Summary of the reference run (e.g. the base model's MPC at the default weight).
    candidates : iterable of mapping
        Summaries of real runs (e.g. the extended model's MPC at several comfort weights).

    Returns
    -------
    dict or None
        ``{"run": summary, "saved_Kh": base K·h - its K·h}`` of the candidate with the fewest
        K·h among those with :meth:`EnergyUse.at_most` ``base``; ``None`` when no candidate
        uses no more energy. ``saved_Kh > 0`` is the claim "less comfort violation at equal
        or lower energy".
    """
    e0 = EnergyUse.of(base)
    ok = [s for s in candidates if EnergyUse.of(s).at_most(e0)]
    if not ok:
        return None
    best = min(ok, key=lambda s: s["comfort_violation_Kh"])
    return {"run": best, "saved_Kh": float(base["comfort_violation_Kh"] - best["comfort_violation_Kh"])}
