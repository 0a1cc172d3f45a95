"""The fitted reading the agent has made on a worker (``quantify.refit``): the same as ``stiction quantify``'s."""

from stiction.quantify.pipeline import FITTED_WARNING, Quantifier
from stiction.quantify.refit import fit_in_worker, worker_window
from stiction.quantify.window import Reading, Window
from stiction.sim.disturbance import Disturbance
from stiction.sim.loop import LoopSpec, simulate


def test_a_worker_fits_a_noisy_level_window_as_the_command_does_and_gives_back_nothing_else():
    spec = LoopSpec(62.3, 21.7, disturbance=Disturbance("gaussian", "output", 0.25), seed=11)
    r = simulate([spec]).kept()
    view = r.op[0][:], r.pv[0][:]
    w = Window("noisy", *view, t_end_s=999.0, process="level", carry=Reading({"fs_pct": 1.0}), defer_reading=True)
    sent = worker_window(w)
    assert sent.carry is None and not sent.defer_reading and sent.op is not w.op and (sent.op == w.op).all()
    reading, draft = fit_in_worker(sent)
    command = Quantifier().quantify([Window("noisy", r.op[0], r.pv[0], t_end_s=999.0, process="level")])[0]
    assert FITTED_WARNING in reading.warnings and draft.method == command.method == "physical"
    assert reading.fields["fs_pct"] == command.fs_pct and reading.fields["fd_pct"] == command.fd_pct
    assert reading.t_end_s == draft.t_end_s == 999.0
    assert abs(draft.fs_pct - spec.fs_pct) <= 2 * draft.fs_se_pct
    clean = simulate([LoopSpec(62.3, 21.7, seed=11)]).kept()  # its slips are read: there is nothing to fit
    assert fit_in_worker(worker_window(Window("clean", clean.op[0], clean.pv[0], process="level"))) is None


def test_a_trusted_slip_reading_the_agent_left_unchecked_is_checked_on_a_worker_as_the_command_checks_it():
    """Hidden effect: a band of 28 % under a sine on the inflow (design seed 3131, loop 43), whose slips read fs 2.4
    off with an error of 0.2.  The agent's quantifier gives that reading and says it is unchecked; the worker's
    reading of the same window is the command's, to the last digit."""
    from stiction.agent.service import FIT_VALVE, SEQUENCE_CHUNKS
    from stiction.sim.grid import random_loops

    spec = random_loops(44, 3131)[43]
    r = simulate([spec]).kept()
    w = Window("sine", r.op[0], r.pv[0], t_end_s=999.0, process="level")
    agent = Quantifier(fit_valve=FIT_VALVE, sequence_chunks=SEQUENCE_CHUNKS).results([w])[0]
    assert agent.unchecked and agent.draft.method == "physical"
    reading, draft = fit_in_worker(worker_window(w), None, SEQUENCE_CHUNKS)
    command = Quantifier(sequence_chunks=SEQUENCE_CHUNKS).quantify([w])[0]
    assert FITTED_WARNING in reading.warnings and draft.method == command.method == "physical"
    assert (reading.fields["fs_pct"], reading.fields["fd_pct"]) == (command.fs_pct, command.fd_pct)
    assert abs(command.fs_pct - spec.fs_pct) <= 2 * command.fs_se_pct < abs(agent.draft.fs_pct - spec.fs_pct)
    assert not Quantifier().results([w])[0].unchecked  # the command checked it itself
