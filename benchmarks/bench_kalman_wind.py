"""Does the MPC's Kalman filter need to follow the wind? (issue 18, session 15)

``harness.mpc.predict.KalmanFilter`` holds one steady-state gain, designed at the nominal airflows and with no
disturbance (``state_matrix(u_nom)``): for a model with ``wind_infiltration`` the state matrix moves with the wind
(``A_k = A + wind_k · Bxv``), so the held gain is the one for calm air. This benchmark compares it with the exact
time-varying filter (covariance carried through ``A(u_k, v_k)`` at every step, started from the steady state at
the first step's wind) on the model as its own plant with the filter's own noise (process 0.05 K per state and
step, measurement 0.05 K), gusty wind 0-12 m/s, a slow mass node (hidden state) in the windy zone, random
airflows, 3,000 steps, six seeds. It prints the mean squared estimation error of every state after 200 steps.

Run: ``python3 benchmarks/bench_kalman_wind.py`` (a few seconds).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_wind_mpc import _base  # noqa: E402

from harness.mpc.predict import KalmanFilter, make_predictor  # noqa: E402
from hvacfmu.models.causes import WindInfiltration  # noqa: E402
from hvacfmu.models.extended import ExtendedModel, ThermalMass  # noqa: E402

Q_STD = R_STD = 0.05


class TrackingFilter(KalmanFilter):
    """The time-varying filter: covariance through the model at each step's airflows and wind."""

    def initialise(self, y, v, q, u):
        x = super().initialise(y, v, q, u)
        A = self.pred.state_matrix(np.asarray(u, float), np.asarray(v, float))
        from harness.mpc.predict import dare_doubling

        C, Qn, Rn = self.pred.C, Q_STD**2 * np.eye(self.pred.nx), R_STD**2 * np.eye(self.pred.ny)
        Pp = dare_doubling(A.T, C.T, Qn, Rn)
        K = np.linalg.solve(C @ Pp @ C.T + Rn, C @ Pp).T
        self.P = (np.eye(self.pred.nx) - K @ C) @ Pp
        return x

    def predict(self, u, v, q):
        A = self.pred.state_matrix(np.asarray(u, float), np.asarray(v, float))
        self.P = A @ self.P @ A.T + Q_STD**2 * np.eye(self.pred.nx)
        return super().predict(u, v, q)

    def correct(self, y):
        C, Rn = self.pred.C, R_STD**2 * np.eye(self.pred.ny)
        self.gain = np.linalg.solve(C @ self.P @ C.T + Rn, C @ self.P).T
        I_KC = np.eye(self.pred.nx) - self.gain @ C
        self.P = I_KC @ self.P @ I_KC.T + self.gain @ Rn @ self.gain.T
        return super().correct(y)


def run(coef, seed, n=3000):
    model = ExtendedModel(
        base=_base(), terms=(WindInfiltration(zone="B", coef=coef), ThermalMass(zone="B", alpha=0.02, beta=0.05))
    )
    pred = make_predictor(model)
    rng = np.random.default_rng(seed)
    k = np.arange(n)
    wind = np.clip(6 + 6 * np.sign(np.sin(2 * np.pi * k / 60)) + rng.normal(0, 0.5, n), 0, 12)
    V = np.column_stack([5 + 5 * np.sin(2 * np.pi * k / 96), np.full(n, 14.0), np.zeros(n), wind])
    U = 0.1 + 0.3 * rng.random((n, 3))
    Q = np.full((n, 3), 0.1)
    x = np.full(pred.nx, 21.0)
    X, Y = [], []
    for i in range(n):
        X.append(x)
        Y.append(pred.C @ x + rng.normal(0, R_STD, pred.ny))
        x = model.step_state(x, U[i], V[i], Q[i]) + rng.normal(0, Q_STD, pred.nx)
    out = {}
    for name, cls in (("held (calm-air gain)", KalmanFilter), ("tracking the wind", TrackingFilter)):
        kf = cls(pred, np.full(3, 0.05), Q_STD, R_STD)
        kf.initialise(Y[0], V[0], Q[0], U[0])
        e = []
        for i in range(1, n):
            kf.predict(U[i - 1], V[i - 1], Q[i - 1])
            kf.correct(Y[i])
            e.append(kf.x - X[i])
        out[name] = np.mean(np.square(e[200:]), axis=0)
    return out


def main():
    print("wind coef [1/step per m/s] | seed | MSE held [K²] | MSE tracking [K²] | change")
    for coef in (0.004, 0.03):
        for seed in range(6):
            r = run(coef, seed)
            held, track = (float(np.mean(v)) for v in r.values())
            print(f"{coef:g} | {seed} | {held:.6f} | {track:.6f} | {100 * (track / held - 1):+.2f} %")


if __name__ == "__main__":
    main()
