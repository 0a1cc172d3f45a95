"""A slow, obviously correct reference for one sample interval of the canonical loop.

The valve ODE of spec/thesis-loop.md, integrated with ``solve_ivp`` together with
the process (Radau, rtol 1e-8, atol 1e-11 in: tightening to 1e-10/1e-13 moves the
end of a slip by < 1e-12 in), with a terminal event wherever a moving stem's
velocity crosses zero.  Stick/slip switching follows the spec literally: a stem
with ``|v| <= delta`` and ``|F| <= Fs`` is stuck; a crossing with ``|F| <= Fs``
sticks; otherwise the stem moves (breaks away) in the force's direction.
Nothing here is shared with ``sim.valve``'s closed form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.integrate import solve_ivp

M = 3.0 / 386.09  # lbf s^2/in
SA = 100.0  # in^2
K = 300.0  # lbf/in
FV = 3.5  # lbf s/in
VS = 0.01  # in/s
DELTA = 1e-6  # in/s
PSI_PER_PCT = 0.12
IN_PER_PCT = 0.04


@dataclass(frozen=True)
class RefState:
    x_in: float  # stem position, in (deviation)
    v_in_s: float
    y_pct: float  # process output


def _process_rate(loop: str, y: float, flow_pct: float) -> float:
    if loop == "level":
        return flow_pct / 15.0
    return (-y + 3.0 * flow_pct) / 10.0


def reference_interval(
    state: RefState, op_pct: float, w_pct: float, fs_lbf: float, fd_lbf: float, loop: str = "level", ts_s: float = 1.0
) -> RefState:
    """Advance the valve and process over one sample interval with OP held."""
    u_psi = PSI_PER_PCT * op_pct

    def force(x):
        return SA * u_psi - K * x

    def moving_rhs(t, s):
        x, v, y = s
        f = force(x)
        if abs(v) <= DELTA:
            a = (f - fs_lbf * np.sign(f)) / M
        else:
            sgn = np.sign(v)
            a = (f - fd_lbf * sgn - FV * v - (fs_lbf - fd_lbf) * np.exp(-((v / VS) ** 2)) * sgn) / M
        return [v, a, _process_rate(loop, y, x / IN_PER_PCT + w_pct)]

    def stuck_rhs(t, s):
        x, _, y = s
        return [0.0, 0.0, _process_rate(loop, y, x / IN_PER_PCT + w_pct)]

    t, s = 0.0, [state.x_in, state.v_in_s, state.y_pct]
    for _ in range(50):  # a handful of stick/slip switches per interval at most
        if t >= ts_s:
            break
        if abs(s[1]) <= DELTA and abs(force(s[0])) <= fs_lbf:
            sol = solve_ivp(stuck_rhs, (t, ts_s), [s[0], 0.0, s[2]], rtol=1e-11, atol=1e-13)
            s, t = list(sol.y[:, -1]), ts_s
            break
        direction = np.sign(s[1]) if abs(s[1]) > DELTA else np.sign(force(s[0]))

        def crossing(t, s, direction=direction):
            # at |v| = DELTA, not 0: below it the moving rhs switches to the breakaway law, and a stem
            # whose force is within fs chatters on that edge (scipy 1.17's Radau gives up there)
            return direction * s[1] - DELTA

        crossing.terminal, crossing.direction = True, -1
        sol = solve_ivp(moving_rhs, (t, ts_s), s, method="Radau", rtol=1e-8, atol=1e-11, events=crossing)
        s, t = list(sol.y[:, -1]), float(sol.t[-1])
        if sol.status == 1:  # velocity crossed zero: stick there (or break away again next pass)
            s[1] = 0.0
    else:
        raise RuntimeError("reference: too many stick/slip switches in one interval")
    return RefState(s[0], s[1], s[2])


def reference_simulate(
    fs_pct: float,
    fd_pct: float,
    duration_s: float = 2000.0,
    loop: str = "level",
    w: np.ndarray | None = None,
    z: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """The whole sampled loop, scalar, every interval through ``reference_interval``.

    Positional PI with ``Ts = 1 s`` and ``SP = 1 %`` (spec).  Slow: for benchmarks and tests only.
    """
    kc, ti = (3.0, 30.0) if loop == "level" else (0.2, 2.0)
    n = int(duration_s)
    w = np.zeros(n) if w is None else w
    z = np.zeros(n) if z is None else z
    fs_lbf, fd_lbf = 5.0 * fs_pct, 5.0 * fd_pct
    state, error_sum = RefState(0.0, 0.0, 0.0), 0.0
    out = {name: np.empty(n) for name in ("op", "pv", "mv")}
    for k in range(n):
        pv = state.y_pct + z[k]
        error = 1.0 - pv
        error_sum += error
        op = kc * (error + error_sum / ti)
        out["op"][k], out["pv"][k], out["mv"][k] = op, pv, state.x_in / IN_PER_PCT
        state = reference_interval(state, op, float(w[k]), fs_lbf, fd_lbf, loop)
    return out
