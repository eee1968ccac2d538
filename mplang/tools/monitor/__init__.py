"""`mpc monitor`: a live dashboard of one controller in the browser (docs/monitor.md).

`server` polls the family's `LiveDevice` (`Family.watch`) and serves the page, its state as
JSON (`GET /api/state`) and a WebSocket of updates (`/ws`) with aiohttp; the page's HTML,
JavaScript and CSS are package data in `assets/`, served from here, so nothing is fetched
from the network at run time.
"""

DEFAULT_PORT = 8194
"""Where the dashboard listens unless --port says otherwise (on 127.0.0.1); here, not in the
command, so that `mpc sim` names it in its help without importing the monitor."""
