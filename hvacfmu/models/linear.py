"""Model A: the linear data-driven zone model of Zhou, Hu & Tomlin (section III).

    x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k)

``kind = "lumped"``: x is the area-weighted mean zone temperature, u the summed
airflow of all VAV boxes. ``kind = "zones"``: x holds the zone temperatures, u
the summed airflow of each zone's boxes. ``q_IG`` [°C per step] is a
time-of-week profile per season.

References
----------
D. Zhou, Q. Hu, C. J. Tomlin, "Model comparison of a data-driven and a physical
model for simulating HVAC systems", eqs. (1) and (temp_propagation_indiv).
"""

from __future__ import annotations

import dataclasses
from typing import Any, ClassVar

import numpy as np
import pandas as pd

from ..errors import ModelError
from .base import (
    FORMAT_VERSION,
    ZoneModel,
    check_shape,
    check_version,
    gains_from_json,
    gains_to_json,
    require_keys,
)


@dataclasses.dataclass(frozen=True, eq=False)
class LinearZoneModel(ZoneModel):
    """Linear zone model (Model A).

    Parameters
    ----------
    kind : {"lumped", "zones"}
    step : float [s]
    outputs : tuple of str
        State/output names: zone names, or ``("floor",)``.
    measured_zones : tuple of str
        Zone names whose ``T_<zone>`` columns are measured.
    output_weights : array (n_outputs, n_measured_zones)
        Measured outputs are ``T_measured @ output_weights.T`` (area weights for lumped).
    vavs : tuple of str
        VAV box names; ``m_<vav>`` columns.
    input_map : array (n_inputs, n_vavs)
        u = m_vav @ input_map.T (sums boxes per zone, or all boxes for lumped).
    disturbances : tuple of str
        Frame columns of v, e.g. ``("T_out", "T_supply", "I_N", "I_E", "I_S", "I_W")``.
    A, B, C : arrays (nx, nx), (nx, nu), (nx, nv)
    gains : dict season -> array (n_time_of_week, nx) [°C per step]
    meta : dict
        Provenance, fit options, uncertainties... (JSON-serialisable).
    """

    kind: str
    step: float
    outputs: tuple
    measured_zones: tuple
    output_weights: np.ndarray
    vavs: tuple
    input_map: np.ndarray
    disturbances: tuple
    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    gains: dict
    meta: dict = dataclasses.field(default_factory=dict)

    KINDS: ClassVar[tuple] = ("lumped", "zones")

    def __post_init__(self):
        if self.kind not in self.KINDS:
            raise ModelError(f"LinearZoneModel kind must be one of {self.KINDS}, got {self.kind!r}")
        nx, nu, nv = len(self.outputs), self.input_map.shape[0] if np.ndim(self.input_map) == 2 else -1, len(self.disturbances)
        set_ = lambda k, v: object.__setattr__(self, k, v)  # noqa: E731 - frozen dataclass normalisation
        set_("outputs", tuple(self.outputs))
        set_("measured_zones", tuple(self.measured_zones))
        set_("vavs", tuple(self.vavs))
        set_("disturbances", tuple(self.disturbances))
        set_("output_weights", check_shape(self.output_weights, (nx, len(self.measured_zones)), "output_weights"))
        set_("input_map", check_shape(self.input_map, (nu, len(self.vavs)), "input_map"))
        set_("A", check_shape(self.A, (nx, nx), "A"))
        set_("B", check_shape(self.B, (nx, nu), "B"))
        set_("C", check_shape(self.C, (nx, nv), "C"))
        set_("gains", {s: check_shape(g, (np.shape(g)[0], nx), f"gains[{s!r}]") for s, g in self.gains.items()})
        if float(self.step) <= 0:
            raise ModelError(f"step must be > 0 s, got {self.step}")

    # --- interface ---------------------------------------------------------
    @property
    def n_states(self) -> int:
        return len(self.outputs)

    @property
    def inputs(self) -> tuple:
        if self.kind == "lumped":
            return ("m_total",)
        return tuple(f"m_{z}" for z in self.outputs)

    def measured_outputs(self, frame: pd.DataFrame) -> np.ndarray:
        T = frame[[f"T_{z}" for z in self.measured_zones]].to_numpy(dtype=float)
        return T @ self.output_weights.T

    def signals(self, frame: pd.DataFrame):
        m = frame[[f"m_{b}" for b in self.vavs]].to_numpy(dtype=float)
        v = frame[list(self.disturbances)].to_numpy(dtype=float)
        return m @ self.input_map.T, v

    def step_state(self, x, u, v, q):
        return x @ self.A.T + u @ self.B.T + v @ self.C.T + q

    def output(self, x):
        return np.asarray(x)

    def equations(self):
        """The model as :class:`~hvacfmu.models.equations.ModelEquations` (linear: no bilinear terms)."""
        from .equations import ModelEquations

        nx = self.n_states
        return ModelEquations(step=float(self.step), A=self.A, Bu=self.B, Bv=self.C, Bq=np.eye(nx),
                              C=np.eye(nx), inputs=self.inputs, disturbances=tuple(self.disturbances),
                              outputs=tuple(self.outputs), gains=dict(self.gains))

    def summary(self) -> str:
        """Readable coefficients, stability, internal-gain levels and fit provenance."""
        ny = len(self.outputs)
        w = max(8, *(len(s) for s in self.outputs))
        fmt = lambda v: f"{v: .4g}".rjust(11)  # noqa: E731
        lines = [f"Model A ({self.kind}), step {self.step:g} s, {ny} state(s)"]
        lines.append("x(k+1) = A x(k) + B u(k) + C v(k) + q_IG(k)")
        lines.append("A:" + "".ljust(w - 2) + "".join(o.rjust(11) for o in self.outputs))
        lines += [o.ljust(w) + "".join(fmt(v) for v in row) for o, row in zip(self.outputs, self.A)]
        lines.append("B [K/step per kg/s]: " + " ".join(f"{o}={v:.4g}" for o, v in zip(self.inputs, np.diag(self.B))))
        lines.append("C:" + "".ljust(w - 2) + "".join(d.rjust(11) for d in self.disturbances))
        lines += [o.ljust(w) + "".join(fmt(v) for v in row) for o, row in zip(self.outputs, self.C)]
        rho = float(np.max(np.abs(np.linalg.eigvals(self.A))))
        lines.append(f"spectral radius of A: {rho:.4f} ({'stable' if rho < 1 else 'UNSTABLE'})")
        for s, g in self.gains.items():
            g = np.asarray(g)
            lines.append(f"q_IG {s}: mean {g.mean():.3f}, min {g.min():.3f}, max {g.max():.3f} K/step")
        bw = (self.meta.get("smoothing") or {}).get("bandwidth_h")
        if bw:
            lines.append("LOESS bandwidths [h]: " + ", ".join(f"{k}={v:g}" for k, v in bw.items()))
        for k in ("data_sha256", "fit_time", "fit_seconds"):
            if k in self.meta:
                lines.append(f"{k}: {self.meta[k]}")
        for msg in self.meta.get("warnings", []) or []:
            lines.append(f"warning: {msg}")
        return "\n".join(lines)

    # --- persistence ---------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "format_version": FORMAT_VERSION,
            "step": float(self.step),
            "outputs": list(self.outputs),
            "measured_zones": list(self.measured_zones),
            "output_weights": self.output_weights.tolist(),
            "vavs": list(self.vavs),
            "input_map": self.input_map.tolist(),
            "disturbances": list(self.disturbances),
            "A": self.A.tolist(),
            "B": self.B.tolist(),
            "C": self.C.tolist(),
            "gains": gains_to_json(self.gains),
            "meta": self.meta,
        }

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> "LinearZoneModel":
        check_version(d)
        keys = ["kind", "step", "outputs", "measured_zones", "output_weights", "vavs", "input_map",
                "disturbances", "A", "B", "C", "gains"]
        require_keys(d, keys, f"{d.get('kind', '?')} model file")
        try:
            nx = len(d["outputs"])
            return cls(
                kind=d["kind"],
                step=float(d["step"]),
                outputs=tuple(d["outputs"]),
                measured_zones=tuple(d["measured_zones"]),
                output_weights=np.asarray(d["output_weights"], dtype=float),
                vavs=tuple(d["vavs"]),
                input_map=np.asarray(d["input_map"], dtype=float),
                disturbances=tuple(d["disturbances"]),
                A=np.asarray(d["A"], dtype=float),
                B=np.asarray(d["B"], dtype=float),
                C=np.asarray(d["C"], dtype=float),
                gains=gains_from_json(d["gains"], nx, float(d["step"])),
                meta=dict(d.get("meta", {})),
            )
        except (TypeError, ValueError) as exc:
            if isinstance(exc, ModelError):
                raise
            raise ModelError(f"malformed {d.get('kind')} model file: {exc}") from None
