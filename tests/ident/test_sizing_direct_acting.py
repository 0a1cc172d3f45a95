"""A direct-acting loop sized as its mirror (``ident.sizing``).  A file of its own beside test_sizing.py: it takes
over a minute, and the test workers take a file at a time."""

import pytest

from stiction.ident.sizing import size


@pytest.mark.slow
def test_a_direct_acting_loop_reads_as_its_mirror():
    """A level held by its outlet valve, a pressure by its vent: PV falls as the valve opens and the controller is
    direct-acting, as in about a third of the measured windows here (OP's and PV's changes correlated +0.3 to
    +0.97).  Recorded so, a sticky loop must read the same S and J as the same loop recorded reverse-acting, its
    process gain of the other sign.  Before: every hypothesis without a free gain was fitted with the canonical
    loop's positive gain, so the diagnosis took another path (the first loop: S 4.13 against 3.79, its process
    self-regulating with a gain of -26 instead of integrating), under an actuator lag the stem's levels read from PV
    were mirrored twice and ran against the drive, and a stem level the data cannot read was walked from 0 % of OP
    (the second loop: S 3.09 against 4.46, J withheld).  Two loops of the independent simulator
    (``sim.two_parameter``), OP recorded mirrored: as -OP, which is exact in floating point.  (As 100 - OP the band's
    search may land elsewhere: it is a needle, and a change of 1e-14 in OP moved the second loop's S from 1.27 to
    1.35, within its error of 0.27-0.34; a sensitivity of its own, not the mirror's.)"""
    from stiction.sim import two_parameter

    loops = two_parameter.draw(10, 4848)
    chosen = [loops[4], loops[8]]  # flow loops, stiction: the first read integrating, the second with a lag
    assert all(lp.kind == "flow" and lp.cause == "stiction" for lp in chosen)
    read = []
    for lp, rec in zip(chosen, two_parameter.simulate(chosen, 1500), strict=True):
        reverse = size(rec.op, rec.pv, lp.ts_s, "reverse", rec.sp)
        direct = size(-rec.op, rec.pv, lp.ts_s, "direct", rec.sp)
        # the first loop's band is withheld since its model valve is dragged (``ident.trust.dragged``: it read S 3.78
        # for a true 7.11), from either side alike
        assert (reverse.read, reverse.why) == (direct.read, direct.why)
        read.append(reverse.read)
        for a, b in ((reverse.s_pct, direct.s_pct), (reverse.j_pct, direct.j_pct), (reverse.s_se_pct, direct.s_se_pct)):
            assert b == pytest.approx(a, rel=1e-9, abs=1e-12, nan_ok=True)
        assert direct.process.kind == reverse.process.kind
        assert direct.process.gain == pytest.approx(-reverse.process.gain, rel=1e-9)
    assert any(read)  # a band read on one side is read on the other, equal to 1e-9
