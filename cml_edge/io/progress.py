"""Progress of long work, for the command line and a library user alike.

:class:`Bar` is a callback ``(done, total)``, what every long function of the package takes
as ``progress`` (``run_protocol``, ``run_scenario``, ``characterize``...): a tqdm bar on
stderr, drawn once it is first called and closed when ``done`` reaches ``total``.
"""

from __future__ import annotations

import sys

from tqdm import tqdm

tqdm.monitor_interval = 0
"""No tqdm monitor thread: a daemon thread, which tqdm wakes at exit while the
interpreter finalizes. The monitor only speeds up bars that stall; ours are redrawn by
their own updates."""


class Bar:
    """A progress callback drawing a bar labelled ``label`` on stderr (``drawn``: False
    keeps it silent, as the command line does when stderr is not a terminal)."""

    def __init__(self, label: str, drawn: bool = True) -> None:
        self.label, self.drawn = label, drawn
        self.bar: tqdm | None = None

    def start(self) -> None:
        """Called before the bar is first drawn."""

    def __call__(self, done: int, total: int) -> None:
        if self.bar is None:
            self.start()
            self.bar = tqdm(total=total, desc=self.label, file=sys.stderr, leave=True,
                            disable=not self.drawn)
        self.bar.update(done - self.bar.n)
        if done >= total:
            self.bar.close()
