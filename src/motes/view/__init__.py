"""A live view in the browser: watch and steer a simulation while it runs (``motes view``).

:class:`~motes.view.server.Viewer` serves a :class:`~motes.view.sources.LiveSource` (a
scene simulated as it is watched, its numbers as controls) or a
:class:`~motes.view.sources.CacheSource` (a cache played back) through viser, a
maintained library that drives a three.js page over a websocket (``pip install
'motes[view]'``; see ``docs/viewer.md``).
"""

from .packet import FramePacket, dequantize, quantize
from .sources import CacheSource, LiveSource
from .timeline import Timeline

__all__ = ["CacheSource", "FramePacket", "LiveSource", "Timeline", "dequantize", "quantize"]
