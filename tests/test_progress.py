"""The progress bar (``hertzsweep.api.progress``): its clock runs between updates, so a
study whose cases take long does not sit at 0 % with a frozen clock; it counts the units
done of the total and is off without a terminal."""

import io
import sys
import time

from hertzsweep.api.progress import progress_bar


class Terminal(io.StringIO):
    """stderr as a terminal (the bar draws only on one)."""

    def isatty(self) -> bool:
        return True


def test_the_clock_runs_between_updates(monkeypatch):
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with progress_bar(4, "study", unit="case", tick=0.05) as update:
        time.sleep(1.2)  # no case finished in this time: the bar is redrawn all the same
        drawn = terminal.getvalue()
        update(1)
    assert "0/4 cases [00:01 elapsed" in drawn  # the elapsed time moved on, with no update
    assert drawn.count("\r") >= 10  # redrawn every tick
    assert "1/4 cases" in terminal.getvalue()


def test_units_and_percent(monkeypatch):
    terminal = Terminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    with progress_bar(100, "branch", unit="%", tick=0.05) as update:
        update(40)
        time.sleep(0.2)  # past tqdm's least interval between draws, and a tick
    assert "branch:  40%|" in terminal.getvalue() and " 40/100 % [" in terminal.getvalue()


def test_no_bar_without_a_terminal(monkeypatch):
    monkeypatch.setattr(sys, "stderr", io.StringIO())
    with progress_bar(4, "study", unit="case") as update:
        assert update is None
    with progress_bar(4, "study", enabled=False) as update:
        assert update is None
