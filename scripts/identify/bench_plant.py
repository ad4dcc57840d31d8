#!/usr/bin/env python3
"""The reference bench simulated by scipy, not by bgc: records for identification and fault
sizing, written as `bgc residuals` and `bgc identify` read them.

The plant (derived under bgc's conventions, `models/backlash_bench.bg`):

    L i' = U0 - Re i - ke we
    Je we' = ke i - fe we - (K z + w(z))
    Js ws' = -fs ws + N (K z + w(z))
    z' = we - N ws
    w(z) = -4 K j0 (1 - exp(-gamma z)) / (1 + exp(-gamma z))

from rest; y1 = we and y2 = ws measured with Gaussian noise. Inputs: an open-loop square
10 ± 5 V of period 10 s, a sine 6 + 12 sin(0.5 t) V, or a closed loop (a PI controller of
the load speed to 2 + sin(0.3 t) rad/s, its voltage recorded as U0). scipy's LSODA (rtol 1e-10,
atol 1e-12) integrates between the input's discontinuities and the faults' instants; the
samples are taken from its dense output at the record's step.

As a module: `simulate(params, input, seconds, faults=(), seed=0, sigma=1e-4, step=1e-3)`
returns (t, U0, y1, y2); `write_csv(path, ...)`. As a script:

    bench_plant.py OUT.csv [--seconds 200] [--input square|sine|closed] [--seed N] [--sigma S]
                   [--draw SEED] [--fault 'j0=3*j0@100'] [--ramp 'j0:0.2:0.6:100:600']

`--draw SEED` draws each of the 11 parameters uniformly within ±3 % of the model's values
(numpy's default_rng(SEED)); the parameters used are printed on standard error.
"""

import argparse
import sys

import numpy as np
from scipy.integrate import solve_ivp

MODEL = {"Re": 0.3, "L": 0.5, "ke": 0.5, "Je": 0.8, "fe": 0.1, "K": 1.0, "N": 5.0,
         "Js": 10.0, "fs": 8.0, "j0": 0.2, "gamma": 2.5}
NAMES = list(MODEL)


def square(t):
    return 10.0 + 5.0 * np.sign(np.sin(0.6283185307179586 * t))


def sine(t):
    return 6.0 + 12.0 * np.sin(0.5 * t)


def reference(t):
    """The closed loop's set point of the load speed, rad/s."""
    return 2.0 + 1.0 * np.sin(0.3 * t)


# The closed loop's PI controller on the load speed, V per rad/s and V per rad.
KP, KI = 3.0, 1.0

# Each input and the period of its discontinuities (None: smooth). "closed": the armature
# voltage a PI controller of the load speed sets (see `closed_loop`), recorded as U0.
INPUTS = {"square": (square, 5.0), "sine": (sine, None), "closed": (reference, None)}


def draw(seed, spread=0.03):
    """The model's parameters, each moved uniformly within ±spread."""
    rng = np.random.default_rng(seed)
    return {k: v * (1.0 + rng.uniform(-spread, spread)) for k, v in MODEL.items()}


def rates(p, u):
    def f(t, x):
        i, we, z, ws = x
        w = -4.0 * p["K"] * p["j0"] * np.tanh(0.5 * p["gamma"] * z)
        torque = p["K"] * z + w
        return [
            (u(t) - p["Re"] * i - p["ke"] * we) / p["L"],
            (p["ke"] * i - p["fe"] * we - torque) / p["Je"],
            we - p["N"] * ws,
            (-p["fs"] * ws + p["N"] * torque) / p["Js"],
        ]
    return f


def closed_loop(p, reference):
    """The plant under a continuous PI controller of the load speed: a fifth state, the
    integral of the speed error; U0 = KP e + KI ∫e, with e the set point less the load
    speed (the controller reads the plant, not the noisy encoder: the loop is the plant's,
    the noise the records')."""
    def f(t, x):
        e = reference(t) - x[3]
        u = KP * e + KI * x[4]
        return rates(p, lambda _t: u)(t, x[:4]) + [e]
    return f


def drifting(p, u, ramps):
    """The rates with parameters drifting linearly (held at their end values after t1)."""
    def f(tt, x):
        q = dict(p)
        for name, v0, v1, t0, t1 in ramps:
            s = min(max((tt - t0) / (t1 - t0), 0.0), 1.0)
            q[name] = v0 + s * (v1 - v0)
        return rates(q, u)(tt, x)
    return f


def simulate(params, input="square", seconds=200.0, faults=(), ramps=(), seed=0,
             sigma=1e-4, step=1e-3, counts=0):
    """faults: (name, factor, at) steps; ramps: (name, start_value, end_value, t0, t1)
    linear drifts of a parameter's value (held at the end value after t1); counts: where
    given, both speeds as encoders of that many counts per revolution read them (`counted`:
    no other noise)."""
    u, period = INPUTS[input]
    n = int(round(seconds / step)) + 1
    t = np.arange(n) * step
    cuts = {0.0, seconds}
    if period:
        cuts.update(np.arange(period, seconds, period).tolist())
    cuts.update(at for (_, _, at) in faults if 0 < at < seconds)
    cuts = sorted(cuts)
    closed = input == "closed"
    state = np.zeros(5 if closed else 4)
    out = np.zeros((n, len(state)))
    U0 = np.zeros(n)
    for a, b in zip(cuts[:-1], cuts[1:]):
        p = dict(params)
        for name, factor, at in faults:
            if a >= at:
                p[name] = params[name] * factor
        # A square input is one level over the stretch (the solver may probe past its end).
        level = u(0.5 * (a + b))
        stretch_u = (lambda tt, level=level: level) if period else u
        if closed:
            f = closed_loop(p, u)
        else:
            f = drifting(p, stretch_u, ramps) if ramps else rates(p, stretch_u)
        sol = solve_ivp(f, (a, b), state, method="LSODA", rtol=1e-10, atol=1e-12,
                        dense_output=True, max_step=0.05)
        if not sol.success:
            raise RuntimeError(sol.message)
        inside = (t >= a - 1e-9) & ((t <= b + 1e-9) if b == cuts[-1] else (t < b - 1e-9))
        out[inside] = sol.sol(t[inside]).T
        if closed:
            x = out[inside]
            U0[inside] = KP * (u(t[inside]) - x[:, 3]) + KI * x[:, 4]
        else:
            U0[inside] = level if period else u(t[inside])
        state = sol.y[:, -1]
    rng = np.random.default_rng(seed)
    y1 = out[:, 1] + sigma * rng.standard_normal(n)
    y2 = out[:, 3] + sigma * rng.standard_normal(n)
    if counts:
        y1, y2 = (counted(out[:, k], step, counts, rng) for k in (1, 3))
    return t, U0, y1, y2


def counted(speed, step, counts, rng):
    """A shaft's speed as an incremental encoder of `counts` per revolution reads it: the
    angle (the speed integrated by the trapezoid rule, from a random phase of the first
    count) counted, and the speed taken as the counts' difference over one sample."""
    angle = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * step)))
    quantum = 2 * np.pi / counts
    seen = np.floor(angle / quantum + rng.uniform()) * quantum
    return np.concatenate(([0.0], np.diff(seen) / step))


def write_csv(path, t, U0, y1, y2):
    with open(path, "w") as out:
        out.write("t,U0,y1,y2\n")
        for row in zip(t, U0, y1, y2):
            out.write("%.6f,%.17g,%.17g,%.17g\n" % row)


def parse_faults(texts):
    """`j0=3*j0@100` -> (j0, 3.0, 100.0)."""
    faults = []
    for text in texts:
        what, at = text.split("@")
        name, factor = what.split("=")
        faults.append((name.strip(), float(factor.split("*")[0]), float(at)))
    return faults


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--seconds", type=float, default=200.0)
    ap.add_argument("--input", choices=list(INPUTS), default="square")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sigma", type=float, default=1e-4)
    ap.add_argument("--draw", type=int)
    ap.add_argument("--fault", action="append", default=[])
    ap.add_argument("--ramp", action="append", default=[])
    ap.add_argument("--counts", type=int, default=0,
                    help="encoders of this many counts per revolution (speed from counts)")
    a = ap.parse_args()
    params = draw(a.draw) if a.draw is not None else dict(MODEL)
    ramps = []
    for text in a.ramp:
        name, v0, v1, t0, t1 = text.split(":")
        ramps.append((name, float(v0), float(v1), float(t0), float(t1)))
    print(" ".join("%s=%.6g" % kv for kv in params.items()), file=sys.stderr)
    write_csv(a.out, *simulate(params, a.input, a.seconds, parse_faults(a.fault), ramps,
                               a.seed, a.sigma, counts=a.counts))


if __name__ == "__main__":
    main()
