"""biped.sim.held_signals: a signal inside the push loop waits for a safe point (between two
compiled calls), then reaches the handler it would have met; a real signal from the OS
(``signal.raise_signal``), Python's own SIGINT handler and a custom SIGTERM handler."""

from __future__ import annotations

import signal

import pytest

from biped.sim.held_signals import HeldSignals


def test_a_signal_waits_for_deliver_then_meets_the_previous_handler():
    seen = []

    def handler(signum, frame):
        seen.append(signum)
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, handler)
    reached = []
    try:
        with pytest.raises(KeyboardInterrupt):
            with HeldSignals() as held:
                signal.raise_signal(signal.SIGTERM)
                for _ in range(1000):  # Python runs its signal handlers between these bytecodes
                    pass
                reached.append(held.pending)  # held, not raised: the block went on
                held.deliver()
                reached.append("after")  # deliver raised: never here
        assert reached == [signal.SIGTERM] and seen == [signal.SIGTERM]
        assert signal.getsignal(signal.SIGTERM) is handler  # restored
    finally:
        signal.signal(signal.SIGTERM, previous)


def test_sigint_becomes_keyboard_interrupt_at_the_blocks_end_and_nothing_without_a_signal():
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    with HeldSignals() as held:
        held.deliver()  # nothing held: nothing happens
    reached = []
    with pytest.raises(KeyboardInterrupt):
        with HeldSignals():
            signal.raise_signal(signal.SIGINT)
            for _ in range(1000):
                pass
            reached.append("end of block")  # the interrupt waits for the block's end
    assert reached == ["end of block"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
