"""A short sample of the link soak (`make soak` runs 1,000): random commands,
some back to back, over a link losing and flipping bytes at 1e-3 both ways.
Each is sent with its check (`*XXXX`) and runs as sent or is refused; none
runs changed, whatever the fault, bytes lost whole or data bits flipped
included; sampling loses nothing."""

from __future__ import annotations

from soak import soak


def test_noisy_link_runs_no_changed_command() -> None:
    t = soak(runs=12, jobs=1, seed=1000)
    assert t["runs"] == 12 and not t["failed_runs"], t
    assert t["mismatch"] == 0, t["examples"]  # none ran changed, the unseen faults included
    assert t["runs_with_unseen"] > 0, t  # and some of the faults were ones only the check sees
    assert t["ran"] >= t["sent"] // 2, t  # most commands still get through
    assert t["fault_in_lost"] + t["fault_out_lost"] > 0, t  # the link really was noisy
    assert not t["sampling_faults"], t  # runs alternate 100 and 1500 Hz: none dropped a set
