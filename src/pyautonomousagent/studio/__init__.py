"""The studio: build a behaviour tree from blocks in the browser, run the swarm live, save
(``pyaa studio gathering``, or ``Studio("gathering").start()`` in a notebook: it serves in a
thread at ``studio.url``). docs/studio.md describes it; :mod:`~pyautonomousagent.studio.server`
lists the routes.
"""

from __future__ import annotations

from pyautonomousagent.studio.server import Studio, has_bundle

__all__ = ["Studio", "has_bundle"]
