"""The studio: build a behaviour tree from blocks in the browser, run the swarm live, save.

    pyaa studio gathering          # serves http://127.0.0.1:PORT/ and prints the address

or from Python (a notebook)::

    from pyautonomousagent.studio import Studio
    studio = Studio("gathering")
    studio.start()                 # serves in a thread; studio.url is the address

docs/studio.md describes it; :mod:`~pyautonomousagent.studio.server` lists the routes.
"""

from __future__ import annotations

from pyautonomousagent.studio.server import Studio, has_bundle

__all__ = ["Studio", "has_bundle"]
