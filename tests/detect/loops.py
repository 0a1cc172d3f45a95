"""Simulated loops the detector's tests hide an effect in."""

from stiction.sim.extensions import Extensions
from stiction.sim.loop import LoopSpec
from stiction.sim.plant_loops import PlantLoop, simulate_plant
from stiction.sim.process import ProcessModel


def slow_flow_loop(fs_pct: float, seed: int, *, fd_share: float = 0.7, controller_gain: float = 0.5,
                   deadband_pct: float = 0.0, load_pct: float = 0.0, sp_steps=()):  # fmt: skip
    """``(op, pv, sp, ts_s)`` of a flow-like loop (gain 1, lag 10 s, dead time 2 s) under a slow PI
    (Ti 150 s), sampled every 10 s: a sticky valve (fs ``fs_pct``, fd ``fd_share`` fs) sticks for
    minutes there while OP winds up, and slips.  ``sp_steps`` as ``PlantLoop.sp_steps``."""
    process = ProcessModel(gain=1.0, time_constant_s=10.0, controller_gain=controller_gain, integral_time_s=150.0)
    extensions = Extensions(dead_time_s=2.0, deadband_pct=deadband_pct)
    spec = LoopSpec(fs_pct, fd_share * fs_pct, process=process, extensions=extensions, seed=seed, sp_pct=50.0)
    loop = PlantLoop(spec, "stiction" if fs_pct else "noise", 10, 0.0, 0.0, 0.05, load_pct, tuple(sp_steps))
    return simulate_plant([loop], warmup_windows=5.0)[0]
