"""`mpc monitor`: a live dashboard of one controller in the browser (docs/monitor.md).

`server` polls the family's `LiveDevice` (`Family.watch`) and serves the page, its state as
JSON (`GET /api/state`) and a WebSocket of updates (`/ws`) with aiohttp; the page's HTML,
JavaScript and CSS are package data in `assets/`, served from here, so nothing is fetched
from the network at run time.
"""
