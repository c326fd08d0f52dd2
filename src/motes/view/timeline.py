"""The frames already simulated, kept (compact) so the timeline can scrub back to them."""

from __future__ import annotations

from collections import OrderedDict

from .packet import FramePacket

__all__ = ["Timeline"]


class Timeline:
    """Frame packets by frame number, within a memory budget.

    Parameters
    ----------
    budget : int
        Bytes the kept frames may take (> 0). Past it the oldest frames are let go
        (:attr:`first` moves up), never the newest.
    """

    def __init__(self, budget: int):
        if budget <= 0:
            raise ValueError(f"budget must be > 0 bytes, got {budget}")
        self.budget = int(budget)
        self._frames: OrderedDict[int, FramePacket] = OrderedDict()
        self.nbytes = 0

    def __len__(self) -> int:
        return len(self._frames)

    def __contains__(self, index: int) -> bool:
        return index in self._frames

    @property
    def first(self) -> int | None:
        """Oldest frame kept (None when empty)."""
        return next(iter(self._frames), None)

    @property
    def last(self) -> int | None:
        """Newest frame kept (None when empty)."""
        return next(reversed(self._frames), None)

    def add(self, packet: FramePacket) -> None:
        """Keep ``packet`` as the newest frame; frames numbered from it on are dropped
        first (a restart numbers frames from 1 again)."""
        for index in [i for i in self._frames if i >= packet.index]:
            self.nbytes -= self._frames.pop(index).nbytes
        self._frames[packet.index] = packet
        self.nbytes += packet.nbytes
        while self.nbytes > self.budget and len(self._frames) > 1:
            _, old = self._frames.popitem(last=False)
            self.nbytes -= old.nbytes

    def get(self, index: int) -> FramePacket:
        """The packet of frame ``index``; KeyError if it is not (or no longer) kept."""
        return self._frames[index]

    def clear(self) -> None:
        self._frames.clear()
        self.nbytes = 0
