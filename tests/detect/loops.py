"""Simulated loops the detector's tests hide an effect in."""

from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec
from stiction.sim.plant_loops import PlantLoop, simulate_plant
from stiction.sim.process import ProcessModel


def slow_flow_loop(fs_pct: float, seed: int, **kwargs):
    """One ``slow_flow_loops`` case."""
    return slow_flow_loops([dict(fs_pct=fs_pct, seed=seed, **kwargs)])[0]


_SIMULATED: dict[tuple, tuple] = {}
"""Each case simulated once per test session (read-only arrays: a test that wrote into one would fail)."""


def slow_flow_loops(cases: list[dict]) -> list:
    """``(op, pv, sp, ts_s)`` of flow-like loops (gain 1, lag 10 s, dead time 2 s) under a slow PI
    (Ti 150 s), sampled every 10 s: a sticky valve (fs ``fs_pct``, fd ``fd_share`` fs) sticks for
    minutes there while OP winds up, and slips.  Each case: ``fs_pct``, ``seed``, and optionally
    ``fd_share`` (0.7), ``controller_gain`` (0.5), ``deadband_pct``, ``load_pct`` (0) and ``sp_steps``
    (as ``PlantLoop.sp_steps``).  The cases not simulated before run together (the simulator is
    vectorised over loops)."""
    full = [
        dict(fd_share=0.7, controller_gain=0.5, deadband_pct=0.0, load_pct=0.0, sp_steps=()) | c for c in cases
    ]
    keys = [tuple(sorted((k, tuple(v) if isinstance(v, tuple | list) else v) for k, v in c.items())) for c in full]
    new = {k: c for k, c in zip(keys, full, strict=True) if k not in _SIMULATED}
    loops = []
    for c in new.values():
        process = ProcessModel(gain=1.0, time_constant_s=10.0, controller_gain=c["controller_gain"],
                               integral_time_s=150.0)  # fmt: skip
        extensions = Extensions(dead_time_s=2.0, deadband_pct=c["deadband_pct"])
        spec = LoopSpec(c["fs_pct"], c["fd_share"] * c["fs_pct"], process=process, extensions=extensions,
                        seed=c["seed"], sp_pct=50.0)  # fmt: skip
        cause = "stiction" if c["fs_pct"] else "noise"
        loops.append(PlantLoop(spec, cause, 10, 0.0, 0.0, 0.05, c["load_pct"], tuple(c["sp_steps"])))
    for k, result in zip(new, simulate_plant(loops, warmup_windows=5.0) if loops else [], strict=True):
        for a in result[:3]:
            if a is not None:
                a.setflags(write=False)
        _SIMULATED[k] = result
    return [_SIMULATED[k] for k in keys]
